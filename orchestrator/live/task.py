"""One task of a live session: a machine run on the session's world, one control tick at a time.

The session's world, controller and context persist between tasks (the cube stays where the
last task put it, the gripper keeps its grip); each task gets its own executor, guards,
blackboard and result. The end of a task is the end of an episode in `orchestrator run`:
after an abort the controlled stop brings the arm to rest; otherwise the arm is brought to
rest gently and the scene settles for `SETTLE_S` before success is judged.
"""

from __future__ import annotations

import time

from ..engine.context import Context
from ..engine.episode import Episode, initial_blackboard, make_executor
from ..engine.executor import Executor, Stopper
from ..engine.result import RunResult
from ..engine.step import StepLoop
from ..engine.tasks import TaskLog
from ..language.load import LoadedScenario

__all__ = ["Task"]


class Task:
    """A machine running in a session.

    Args:
        task_id: The session's id for it (`<epoch>-<n>`).
        loaded: The task's machine, loaded with the scenario and the command's `--set`.
        ctx: The session's context (its blackboard and metrics are replaced).
        machine_ref: The machine as the command named it.
        loop: Steps the session's world (shared by its tasks).
    """

    def __init__(
        self,
        task_id: str,
        loaded: LoadedScenario,
        ctx: Context,
        machine_ref: str,
        loop: StepLoop,
    ) -> None:
        self.id = task_id
        self.loop = loop
        self.loaded = loaded
        self.ctx = ctx
        self.machine_ref = machine_ref
        self.executor: Executor | None = None
        self.episode: Episode | None = None
        self.wall0 = 0.0
        self.result: RunResult | None = None
        self.stopped_by: str | None = None
        self.owner = ""
        """The owner token of the client that sent it: its heartbeats feed the watchdog."""
        self.client = ""
        """The name that client gave (for messages)."""
        self.accepted_wall = time.perf_counter()
        """Wall time the session accepted it [s] (perf_counter)."""
        self.beat_wall: float | None = None
        """Wall time of its owner's last heartbeat [s] (perf_counter; None: none yet)."""
        self.pause_wanted = False
        """The last pause/resume the session delivered was a pause (repeats are not sent)."""

    # -- lifecycle ------------------------------------------------------------------------
    def start(self, observers: list | None = None) -> None:
        """Start the machine on the session's world (`observers` watch it: a recorder)."""
        ctx, scn, loop = self.ctx, self.loaded.scenario, self.loop
        ctx.world.release_brakes()  # engaged by the last task's stop, if any: motors take over
        ctx.blackboard = initial_blackboard(self.loaded.machine, scn.blackboard)
        ctx.metrics = {}
        ctx.tasks = TaskLog()
        ctx.clock_offset = 0.0
        ctx.clock_rate = 1.0
        ctx.ik_target = None
        ctx.planned_path = None
        loop.reset_peaks()
        loop.set_observers(observers or [])
        self.executor = make_executor(self.loaded, ctx)
        self.episode = Episode(self.loaded, ctx, self.executor, loop, observers or [])
        self.wall0 = time.perf_counter()
        for obs in observers or []:
            obs.on_start(ctx, self.executor)
        self.episode.start()

    def resume(self, observers: list | None = None) -> None:
        """Continue this task as restored from a session snapshot (live/snapshots.py): its
        machine where it was; `observers` told `on_resume` (or `on_start`)."""
        assert self.episode is not None and self.executor is not None
        observers = observers or []
        self.loop.set_observers(observers)
        self.episode.observers = list(observers)
        self.wall0 = time.perf_counter()
        for obs in observers:
            resume = getattr(obs, "on_resume", None)
            (resume if resume is not None else obs.on_start)(self.ctx, self.executor)

    @property
    def t0(self) -> float:
        """Simulated time the task started [s]."""
        return self.episode.t0 if self.episode is not None else 0.0

    @property
    def leaf(self) -> str:
        return self.executor.leaf if self.executor is not None else ""

    @property
    def active_stop(self) -> Stopper | None:
        """The controlled stop the physics step must drive, if one is under way."""
        return self.episode.active_stop if self.episode is not None else None

    def stop(self, reason: str) -> None:
        """The `stop` command: a machine that declares a `stop` event gets it (its own way of
        stopping, e.g. `events: {stop: GO_HOME}`); any other ends where it is (`failed`, the
        arm brought to rest gently)."""
        ex = self.executor
        if ex is None or ex.done or self.episode is None:
            return
        self.stopped_by = reason
        if "stop" in ex.root.events:
            ex.event("stop", reason)
        else:
            self.episode.halt(reason)

    def tick(self) -> bool:
        """One control tick of the machine, the end of the task and the physics.

        Returns:
            True when the task is over (the arm at rest, the result built).
        """
        assert self.episode is not None
        if not self.episode.tick():
            return False
        result = self.episode.result(self.ctx.world.seed, time.perf_counter() - self.wall0)
        result.metrics["t_start"] = round(self.t0, 6)
        if self.stopped_by is not None:
            result.metrics["stopped_by"] = self.stopped_by
        self.result = result
        return True
