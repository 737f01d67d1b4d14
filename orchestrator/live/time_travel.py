"""A session's `snapshot`, `restore` and `reload` commands: checked when they arrive (the
answer says why one is refused), applied at the start of the next control tick.

* `snapshot [--name NAME]`: live/snapshots.py writes the world and the running task; the
  answer names the file, an event says when it was written.
* `restore NAME`: the snapshot is read and checked when the command arrives (signature,
  version, scenario), put in place at the start of the next tick (live/snapshots.py).
* `reload MACHINE`: the file is loaded and validated as a `run`'s machine is, and must fit the
  running task (engine/reload.py); refused with the validator's errors otherwise, and the task
  runs on unchanged. Applied, every level of the task adopts the new definition as it enters
  its next state: the state running finishes as it was.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

from ..engine.cell import Cell
from ..engine.reload import apply_reload, reload_problems
from ..engine.snapshot import SnapshotError
from ..exceptions import ConfigError
from ..language.load import load_scenario
from ..language.loading import MachineNode
from . import machine_ref
from .protocol import Command, Reply
from .snapshots import SessionState, read_session, snapshot_file, write_session
from .task import Task

if TYPE_CHECKING:
    from ..engine.context import Context
    from ..engine.step import StepLoop
    from ..language.load import LoadedScenario
    from ..world.world import World
    from .blocked import Blocked
    from .snapshot_writer import SnapshotWriter


class Session(Protocol):
    """What of a live session (live/session.py) the time-travel commands read and change:
    a structural type, so this module does not import the session that calls it."""

    allow_paths: tuple[Path | str, ...]
    blocked: Blocked
    cell: Cell
    ctx: Context
    epoch: str
    error: str | None
    estopped: bool
    idle_stop: Any
    probe: Any
    loaded: LoadedScenario
    name: str
    publish: Callable[[str, dict[str, Any]], None]
    scenario_ref: str
    snapshot_dir: Path
    snapshots: SnapshotWriter
    task: Task | None
    ticks: int

    @property
    def world(self) -> World: ...
    @property
    def loop(self) -> StepLoop: ...
    @property
    def state(self) -> str: ...
    def drop_all(self, reason: str) -> None: ...
    def next_task_id(self) -> str: ...
    def restarted_clock(self) -> None: ...
    def resume_task(self, task: Task) -> None: ...


__all__ = ["TIME_TRAVEL", "apply_time_travel", "capture", "submit_time_travel"]

TIME_TRAVEL = ("snapshot", "restore", "reload")
"""The commands this module handles."""
RESTORE_WAIT_S = 2.0
"""Longest a `restore` waits for the snapshot of its name still being written [s] (it holds
up the command thread: short, then refused; an e-stop has its own path)."""


def submit_time_travel(session: Session, cmd: Command) -> tuple[Reply, Any]:
    """Check a `snapshot`, `restore` or `reload` as it arrives (any thread).

    Returns:
        The answer, and what `apply_time_travel` needs if it was accepted.
    """
    op = cmd.op
    if op == "snapshot":
        name = cmd.snapshot or f"{session.name}-{session.epoch}-tick{session.ticks}"
        try:
            path = snapshot_file(session.snapshot_dir, name)
        except SnapshotError as exc:
            return Reply(accepted=False, reason=str(exc)), None
        refused = session.snapshots.admit()
        if refused is not None:
            return Reply(accepted=False, reason=refused), None
        return Reply(accepted=True, snapshot=str(path)), path
    if op == "restore":
        if not cmd.snapshot:
            return Reply(accepted=False, reason="restore: name the snapshot (--name)"), None
        if session.estopped or session.error:
            why = f"the robot is {session.state}: send `reset` first, then restore"
            return Reply(accepted=False, reason=why), None
        try:
            path = snapshot_file(session.snapshot_dir, cmd.snapshot)
            if not session.snapshots.wait_for(path, RESTORE_WAIT_S):
                why = (f"{path}: still being written after {RESTORE_WAIT_S} s; restore it "
                       "once the `snapshot` event says it is written")  # fmt: skip
                return Reply(accepted=False, reason=why), None
            state, header = read_session(path, session.loaded)
        except SnapshotError as exc:
            return Reply(accepted=False, reason=str(exc)), None
        return Reply(accepted=True, snapshot=str(path)), (path, state, header)
    return _submit_reload(session, cmd)


def _submit_reload(session: Session, cmd: Command) -> tuple[Reply, Any]:
    if not cmd.machine:
        return Reply(accepted=False, reason="reload: name the machine file (MACHINE)"), None
    task = session.task
    if task is None or task.executor is None or task.executor.done:
        why = "no task is running: the next `run` loads the machine file as it is then"
        return Reply(accepted=False, reason=why), None
    refused = machine_ref.refusal(cmd.machine, session.loaded.path, session.allow_paths)
    if refused is not None:  # one answer for missing and not allowed
        return Reply(accepted=False, reason=refused), None
    try:
        loaded = load_scenario(
            session.scenario_ref, allow_paths=session.allow_paths, machine=cmd.machine
        )
    except ConfigError as exc:  # the validator's errors, every one: nothing changes
        return Reply(accepted=False, reason=str(exc)), None
    problems = reload_problems(task.executor, loaded.machine)
    if problems:
        return Reply(accepted=False, reason="reload: " + "; ".join(problems)), None
    return Reply(accepted=True, task=task.id), (task, loaded.machine)


def apply_time_travel(session: Session, cmd: Command, payload: Any) -> None:
    """Apply an accepted `snapshot`, `restore` or `reload` (the session's loop, between two
    control ticks)."""
    if cmd.op == "snapshot":
        _snapshot(session, payload)
    elif cmd.op == "restore":
        _restore(session, cmd, *payload)
    else:
        _reload(session, *payload)


def _snapshot(session: Session, path: Any) -> None:
    """Hand the snapshot to the writer: it is captured at the start of a control tick and
    written off the loop (live/snapshot_writer.py)."""
    session.snapshots.add(path)


def capture(session: Session, path: Path) -> int:
    """Write the session's state as it is now to `path` (in the snapshot writer's child
    process); returns the file's size [bytes]."""
    state = SessionState(  # never the latch (ESTOPPED, ERROR): that is the session's own
        session.world, session.ctx, session.cell.controller, session.loop, session.task,
        session.idle_stop, session.blocked,
    )  # fmt: skip
    return write_session(path, state, session.loaded, session.name)


def _restore(
    session: Session, cmd: Command, path: Any, state: SessionState, header: dict[str, Any]
) -> None:
    session.drop_all(f"the session was restored from {path}")
    cell = state.ctx.cell
    assert isinstance(cell, Cell)  # read_session builds one
    session.cell, session.ctx = cell, state.ctx  # the world's cell, its idle context
    session.idle_stop, session.blocked = state.idle_stop, state.blocked
    # the latch is the session's, never the snapshot's: a restore keeps ESTOPPED and ERROR
    # as they are (it is refused while either holds) and a snapshot does not carry them
    session.loop.set_observers([session.probe])
    session.restarted_clock()
    task = state.task
    event: dict[str, Any] = {"event": "restore", "snapshot": str(path), "t": header.get("t"),
                             "tick": header.get("tick"), "task": None,
                             "snapshot_task": header.get("task")}  # fmt: skip
    if task is not None and task.executor is not None and not task.executor.done:
        task.id = session.next_task_id()
        task.owner, task.client = cmd.owner, cmd.client
        task.accepted_wall, task.beat_wall = time.perf_counter(), None
        session.resume_task(task)
        event["task"] = task.id
    session.publish("events", event)


def _reload(session: Session, task: Task, root: MachineNode) -> None:
    ex = task.executor
    if session.task is not task or ex is None or ex.done:
        session.publish("events", {"event": "reload_refused", "task": task.id,
                                   "reason": "the task ended before the reload"})  # fmt: skip
        return
    problems = reload_problems(ex, root)  # again: states may have changed since it arrived
    if problems:
        session.publish("events", {"event": "reload_refused", "task": task.id,
                                   "reason": "; ".join(problems)})  # fmt: skip
        return
    apply_reload(ex, root)
    session.publish("events", {"event": "reload", "task": task.id, "machine": root.name,
                               "t": round(session.ctx.t, 6)})  # fmt: skip
