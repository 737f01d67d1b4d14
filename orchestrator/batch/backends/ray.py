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

__all__ = ["EPISODE_MODULES", "RayBackend", "import_ray", "worker_imports"]

IN_FLIGHT_PER_WORKER = 2
"""Tasks submitted per worker slot: one running, one waiting, so no CPU idles between tasks."""
EPISODE_MODULES = ("orchestrator.batch.episode", "orchestrator.robots", "orchestrator.skills")
"""What a Ray worker imports to run an episode; checked once on the cluster before the batch."""
PROBE_TIMEOUT_S = 120.0
"""How long the check may wait for a worker process to start (a cold node takes seconds)."""


def worker_imports(modules: Sequence[str]) -> str | None:
    """Run on a Ray worker: None if it imports `modules`, else the error. A node whose `ray
    start` ran under another Python than the one this package is installed in finds the
    `orchestrator` folder (the working directory is on its path) but not the packages the
    install maps into it: `No module named 'orchestrator.robots'`, for every episode."""
    import importlib

    try:
        for module in modules:
            importlib.import_module(module)
    except ImportError as exc:
        return f"{type(exc).__name__}: {exc}"
    return None


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
        self.probe: Sequence[str] = EPISODE_MODULES
        """The modules a worker must import before the batch starts (`worker_imports`)."""

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
        try:
            self._check_workers()
        except BaseException:
            if started:
                ray.shutdown()
            raise
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

    def _check_workers(self) -> None:
        """One task on the cluster imports what an episode needs (`worker_imports`; it needs no
        CPU, so a busy cluster runs it at once).

        Raises:
            BatchError: A worker cannot: the message says why and how to start the nodes.
        """
        ray = self.ray
        probe = ray.remote(num_cpus=0, max_retries=0)(worker_imports)
        try:
            problem = ray.get(probe.remote(list(self.probe)), timeout=PROBE_TIMEOUT_S)
        except ray.exceptions.GetTimeoutError:
            return  # no worker started in time: each episode's line will say what went wrong
        except ray.exceptions.RayError as exc:  # e.g. this module does not unpickle there
            lines = str(exc).strip().splitlines()
            problem = lines[-1] if lines else type(exc).__name__
        if problem is not None:
            raise BatchError(
                f"the Ray workers cannot run an episode ({problem}): every node must be "
                "started by the Python that has embodied-orchestrator installed (`python -m "
                "ray.scripts.scripts start ...` when the `ray` on PATH belongs to another "
                "one), and scenario files must be at the same path there"
            )
