"""The local backend: a pool of worker processes on this machine, one episode each at a time.

Each worker gets one task at a time over its own pipe, so when a worker process dies the
parent knows exactly which episode it was running: that episode is retried once on a fresh
worker, then recorded as `error`. Workers are forked from a fork server that imported the
framework once, so starting (or replacing) one is cheap and never inherits the parent's
threads (the progress bar's). A fork server keeps the environment it was started with, so each
worker is handed the parent's environment as it is when its batch starts (the snapshot key's
location, `$ORCHESTRATOR_SNAPSHOT_KEY`, and anything else a run reads from it).
"""

from __future__ import annotations

import math
import multiprocessing
import os
import signal
import time
from collections import deque
from collections.abc import Iterator, Sequence
from multiprocessing.connection import Connection, wait
from typing import Any

from ..task import EpisodeTask, error_line
from .base import MAX_ATTEMPTS, Backend, RunFn

__all__ = ["LocalBackend"]

_PRELOAD = ["orchestrator.batch.episode"]
_STOP_TIMEOUT_S = 5.0
_HARD_GRACE_S = 60.0
"""Wall time past an episode's own limit after which its worker is killed [s] (the episode
stops itself at its limit; this catches one stuck inside a single physics step)."""


class LocalBackend(Backend):
    """Worker processes on this machine.

    Args:
        workers: Number of worker processes.
        run_fn: Runs one episode in a worker (default: `episode.run_task`); must be a
            module-level function so that workers can import it.
        start_method: `forkserver` (default), `spawn` or `fork`.
    """

    name = "local"

    def __init__(
        self, workers: int, run_fn: RunFn | None = None, start_method: str = "forkserver"
    ) -> None:
        super().__init__(workers)
        self.run_fn = run_fn
        self.start_method = start_method

    def run(self, tasks: Sequence[EpisodeTask]) -> Iterator[dict[str, Any]]:
        run_fn = self.run_fn
        if run_fn is None:
            from ..episode import run_task

            run_fn = run_task
        mp = multiprocessing.get_context(self.start_method)
        if self.start_method == "forkserver":
            mp.set_forkserver_preload(_PRELOAD)  # type: ignore[attr-defined]
        queue = deque(tasks)
        attempts: dict[int, int] = {}
        pool = [_Worker(mp, run_fn) for _ in range(min(self.workers, len(queue)))]
        try:
            while queue or any(w.task is not None for w in pool):
                for w in pool:
                    if w.task is None and queue:
                        w.assign(queue.popleft())
                busy = [w for w in pool if w.task is not None]
                deadlines = [w.deadline for w in busy]
                timeout = max(0.0, min(deadlines) - time.monotonic()) if deadlines else None
                wait([h for w in busy for h in (w.conn, w.process.sentinel)], timeout)
                for i, w in enumerate(pool):
                    task = w.task
                    if task is None:
                        continue
                    line = w.poll()
                    if line is None and time.monotonic() > w.deadline:
                        # the episode's own wall limit did not stop it (stuck in one step)
                        w.close()
                        pool[i] = _Worker(mp, run_fn)
                        yield error_line(
                            task,
                            "WallTimeExceeded",
                            f"the episode ran past its wall-clock limit of {task.max_wall_s:g} s "
                            f"and did not stop within {_HARD_GRACE_S:g} s more: its worker was "
                            "killed",
                            None,
                        )
                        continue
                    if line is None and not w.alive:
                        line = w.poll()  # it may have sent its line just before it died
                    if line is not None:
                        yield line
                    elif not w.alive:
                        why = w.death()
                        pool[i] = _Worker(mp, run_fn)
                        attempts[task.seed] = attempts.get(task.seed, 0) + 1
                        if attempts[task.seed] < MAX_ATTEMPTS:
                            queue.appendleft(task)
                        else:
                            yield error_line(
                                task,
                                "WorkerDied",
                                f"the worker process died running this episode ({why}), "
                                f"{attempts[task.seed]} times",
                                None,
                            )
        finally:
            for w in pool:
                w.close()


class _Worker:
    """One worker process and the parent's end of its pipe."""

    def __init__(self, mp: Any, run_fn: RunFn) -> None:
        self.conn, child = mp.Pipe(duplex=True)
        env = dict(os.environ)
        self.process = mp.Process(target=_worker_main, args=(child, run_fn, env), daemon=True)
        self.process.start()
        child.close()  # so that the parent sees EOF when the worker dies
        self.task: EpisodeTask | None = None
        self.deadline = math.inf

    @property
    def alive(self) -> bool:
        return self.process.is_alive()

    def assign(self, task: EpisodeTask) -> None:
        self.task = task
        if task.max_wall_s is not None:
            self.deadline = time.monotonic() + task.max_wall_s + _HARD_GRACE_S
        try:
            self.conn.send(task)
        except (BrokenPipeError, ConnectionResetError):
            pass  # it died; poll() finds out

    def poll(self) -> dict[str, Any] | None:
        """The finished episode's line, or None (still running, or dead)."""
        try:
            if not self.conn.poll():
                return None
            line: dict[str, Any] = self.conn.recv()
        except (EOFError, OSError):
            self.process.join(_STOP_TIMEOUT_S)
            return None
        self.task = None
        self.deadline = math.inf
        return line

    def death(self) -> str:
        """How the process ended, in words."""
        self.process.join(_STOP_TIMEOUT_S)
        code = self.process.exitcode
        self.conn.close()
        if code is None:
            return "no exit code"
        if code < 0:
            try:
                return f"killed by {signal.Signals(-code).name}"
            except ValueError:
                return f"killed by signal {-code}"
        return f"exit code {code}"

    def close(self) -> None:
        """Stop the worker: ask it to exit when idle, terminate it when busy or stuck."""
        if self.process.is_alive() and self.task is None:
            try:
                self.conn.send(None)
            except OSError:
                pass
            self.process.join(_STOP_TIMEOUT_S)
        if self.process.is_alive():
            self.process.terminate()
            self.process.join(_STOP_TIMEOUT_S)
        if self.process.is_alive():
            self.process.kill()
            self.process.join()
        self.conn.close()


def _worker_main(conn: Connection, run_fn: RunFn, env: dict[str, str]) -> None:
    """A worker: run tasks from the pipe until told to stop (None) or the parent is gone."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the parent's to handle
    os.environ.clear()  # the parent's environment now, not the fork server's at its start
    os.environ.update(env)
    try:
        while True:
            task = conn.recv()
            if task is None:
                return
            conn.send(run_fn(task))
    except (EOFError, OSError):
        return
