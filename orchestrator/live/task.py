"""One task of a live session: a machine run on the session's world, one control tick at a time.

The session's cell persists between tasks (engine/cell.py: the world, the controller, the hand
and the sensors — the cube stays where the last task put it, the gripper keeps its grip);
each task is an episode of its own: a fresh `Context` (blackboard, events, metrics, task log,
skills' clock, grasp heights, camera shots), its own executor, guards and result. The end of
a task is the end of an episode in `orchestrator run`: after an abort the controlled stop
brings the arm to rest; otherwise the arm is brought to rest gently and the scene settles for
`SETTLE_S` before success is judged.
"""

from __future__ import annotations

import time
from typing import Protocol, runtime_checkable

from ..engine.cell import Cell
from ..engine.context import Context
from ..engine.episode import Episode, initial_blackboard, make_executor
from ..engine.executor import Executor, Stopper
from ..engine.result import RunResult
from ..engine.runner import tell_start
from ..language.load import LoadedScenario

__all__ = ["Closeable", "Task"]


@runtime_checkable
class Closeable(Protocol):
    """A task's observer that holds something to free when its task is dropped without an
    end (a restore ends it where it is): a recorder closes its recording (live/session.py)."""

    def close(self) -> None: ...


class Task:
    """A machine running in a session.

    Args:
        task_id: The session's id for it (`<epoch>-<n>`).
        loaded: The task's machine, loaded with the scenario and the command's `--set`.
        cell: The session's cell (its world and hardware; its step loop steps the task).
        machine_ref: The machine as the command named it.

    Attributes:
        ctx: The task's own context, made when it starts (None before).
    """

    def __init__(
        self,
        task_id: str,
        loaded: LoadedScenario,
        cell: Cell,
        machine_ref: str,
    ) -> None:
        self.id = task_id
        self.cell = cell
        self.loop = cell.loop
        self.loaded = loaded
        self.ctx: Context | None = None
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
    def start(self, observers: list | None = None, cell: Cell | None = None) -> None:
        """Start the machine on the session's world, in a fresh context (`observers` watch it:
        a recorder). `cell`: the session's cell as it is now. A `restore` applied between this
        task's acceptance and its start replaced the cell it was made with; it runs on the
        world that is (on the replaced one it stepped a second world, with its own time,
        beside the session's: the arm the session reports and e-stops was not the one moving).
        """
        if cell is not None:
            self.cell, self.loop = cell, cell.loop
        scn, loop = self.loaded.scenario, self.loop
        self.cell.world.release_brakes()  # engaged by the last task's stop: motors take over
        self.ctx = ctx = Context(self.cell, initial_blackboard(self.loaded.machine, scn.blackboard))
        loop.bind(ctx)
        loop.set_observers(observers or [])
        self.executor = make_executor(self.loaded, ctx)
        self.episode = Episode(self.loaded, ctx, self.executor, loop, observers or [])
        self.wall0 = time.perf_counter()
        tell_start(observers or [], ctx, self.executor, resumed=False)
        self.episode.start()

    def resume(self, observers: list | None = None) -> None:
        """Continue this task as restored from a session snapshot (live/snapshots.py): its
        machine where it was; `observers` told `on_resume` where they implement
        `ResumeObserver` (else `on_start`)."""
        assert self.episode is not None and self.executor is not None and self.ctx is not None
        observers = observers or []
        if self.loop.ctx is not self.ctx:
            self.loop.bind(self.ctx)
        self.loop.set_observers(observers)
        self.episode.observers = list(observers)
        self.wall0 = time.perf_counter()
        tell_start(observers, self.ctx, self.executor, resumed=True)

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
        result = self.episode.result(self.cell.world.seed, time.perf_counter() - self.wall0)
        result.metrics["t_start"] = round(self.t0, 6)
        if self.stopped_by is not None:
            result.metrics["stopped_by"] = self.stopped_by
        self.result = result
        return True
