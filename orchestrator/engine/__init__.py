"""Running a machine: the executor (the brain), the runner (the loop on simulated time), the
context skills and guards see, the blackboard, success checks and the run result."""

from .context import Context, Event
from .result import RunResult
from .runner import Observer, run_episode

__all__ = ["Context", "Event", "Observer", "RunResult", "run_episode"]
