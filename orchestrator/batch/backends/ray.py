"""The Ray backend: one Ray task per episode, a bounded number in flight.

Ray is an optional extra (`pip install 'embodied-orchestrator[ray]'`), imported only here.
Without an address it starts a local Ray with `workers` CPUs; with `--address` (or
`$RAY_ADDRESS`) it joins that cluster, whose nodes need the same `orchestrator` installed
(scenario files must be at the same path there; bundled names always resolve).
"""

from __future__ import annotations

import os
from collections import deque
from collections.abc import Iterator, Sequence
from types import ModuleType
from typing import Any

from ..config import default_workers
from ..exceptions import BatchError
from ..task import EpisodeTask, error_line
from .base import MAX_ATTEMPTS, Backend, RunFn

__all__ = ["RayBackend", "import_ray"]

IN_FLIGHT_PER_WORKER = 2
"""Tasks submitted per worker slot: one running, one waiting, so no CPU idles between tasks."""


def import_ray() -> ModuleType:
    """Import Ray, or say how to install it.

    Raises:
        BatchError: Ray is not installed.
    """
    try:
        import ray
    except ImportError:
        raise BatchError(
            "the ray backend needs Ray, which is not installed: "
            "pip install 'embodied-orchestrator[ray]' (or use --backend local)"
        ) from None
    return ray


class RayBackend(Backend):
    """Ray tasks on a local Ray or a cluster.

    Args:
        workers: CPUs of the local Ray this starts (None: every core); on a cluster, the
            episodes to run at once (None: all its CPUs). At most `2 * workers` tasks are in
            flight.
        address: Cluster address (`ray://...` or `host:port`); None: `$RAY_ADDRESS`, else
            a local Ray.
        run_fn: Runs one episode (default: `episode.run_task`).
    """

    name = "ray"

    def __init__(
        self, workers: int | None, address: str | None = None, run_fn: RunFn | None = None
    ) -> None:
        super().__init__(workers or default_workers())
        self.requested_workers = workers
        self.address = address or os.environ.get("RAY_ADDRESS") or None
        self.run_fn = run_fn
        self.ray = import_ray()

    def run(self, tasks: Sequence[EpisodeTask]) -> Iterator[dict[str, Any]]:
        ray = self.ray
        run_fn = self.run_fn
        if run_fn is None:
            from ..episode import run_task

            run_fn = run_task
        started = False
        if not ray.is_initialized():
            common: dict[str, Any] = {"logging_level": "WARNING", "log_to_driver": False}
            if self.address:
                ray.init(address=self.address, **common)
            else:
                ray.init(num_cpus=self.workers, include_dashboard=False, **common)
            started = True
        slots = self.requested_workers or max(1, int(ray.cluster_resources().get("CPU", 1)))
        self.workers = slots
        # Ray re-runs a task whose worker process died (max_retries), then raises.
        remote = ray.remote(num_cpus=1, max_retries=MAX_ATTEMPTS - 1)(run_fn)
        queue = deque(tasks)
        in_flight: dict[Any, EpisodeTask] = {}
        try:
            while queue or in_flight:
                while queue and len(in_flight) < IN_FLIGHT_PER_WORKER * slots:
                    task = queue.popleft()
                    in_flight[remote.remote(task)] = task
                done, _ = ray.wait(list(in_flight), num_returns=1)
                for ref in done:
                    task = in_flight.pop(ref)
                    try:
                        line: dict[str, Any] = ray.get(ref)
                    except ray.exceptions.RayError as exc:
                        text = str(exc).strip()
                        line = error_line(
                            task,
                            type(exc).__name__,
                            text.splitlines()[0] if text else type(exc).__name__,
                            text,
                        )
                    yield line
        finally:
            for ref in in_flight:
                ray.cancel(ref, force=True)
            if started:
                ray.shutdown()
