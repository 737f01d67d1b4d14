"""A live session's snapshots: the world it keeps, and the task running on it, if any.

`snapshot [NAME]` writes `<folder>/<NAME>.snap` at the start of the next control tick: the
world, the controller, the step loop, the running task (its machine at every level, its
skills mid-motion), the idle world's stop, and whether the session is blocked; never whether it
is e-stopped or in error (the latch is the session's own: a restore neither sets nor clears
it, and is refused while it holds, when it arrives and again when it is applied). `restore NAME`
puts one back at the start of a control tick: the running task and the
queue are dropped (their clients are told), and the task of the snapshot, if it had one,
continues as a new task owned by whoever restored it. A snapshot is written and read as
`orchestrator run`'s are (engine/snapshot: signed with the key of the user the session runs
as, refused if another version or another scenario wrote it). Names are plain (letters,
digits, `_`, `-`, `.`; no path): a client never names a file outside the session's folder.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..engine.context import Context
from ..engine.safety_stop import SafetyStop
from ..engine.snapshot import SnapshotError, local_skill_files, read_snapshot, write_snapshot
from ..engine.snapshot.pickler import dumps, loads
from ..engine.snapshot.run_snapshot import check_versions, detached, file_digest
from ..engine.snapshot.versions import versions
from ..engine.step import StepLoop
from ..language.load import LoadedScenario
from ..robots import Controller
from ..world.world import World
from .blocked import Blocked
from .task import Task

__all__ = ["SessionState", "read_session", "snapshot_file", "write_session"]

_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]{0,63}")


@dataclass
class SessionState:
    """What a session snapshot holds (everything the session's next ticks depend on), except
    the latch: whether the session is e-stopped or in error is never written nor read back."""

    world: World
    ctx: Context
    controller: Controller
    loop: StepLoop
    task: Task | None
    idle_stop: SafetyStop | None
    blocked: Blocked


def snapshot_file(folder: Path, name: str) -> Path:
    """`folder/<name>.snap`.

    Raises:
        SnapshotError: `name` is not a plain name (a path, `..`, too long, empty).
    """
    stem = name.removesuffix(".snap")
    if not _NAME.fullmatch(stem) or ".." in stem:
        raise SnapshotError(
            f"snapshot name {name[:80]!r}: give a plain name of up to 64 letters, digits, "
            "'_', '-' or '.' (no folder: snapshots stay in the session's folder)"
        )
    return Path(folder) / f"{stem}.snap"


def write_session(path: Path, state: SessionState, loaded: LoadedScenario, session: str) -> int:
    """Write `state` as a signed snapshot; returns its size [bytes]."""
    ctx, task = state.ctx, state.task
    header: dict[str, Any] = {
        "kind": "session",
        "session": session,
        "scenario": loaded.name,
        "scenario_file": str(loaded.path),
        "scenario_sha256": file_digest(loaded.path),
        "seed": ctx.world.seed,
        "t": round(ctx.t, 6),
        "tick": ctx.tick,
        "state": task.leaf if task is not None else None,
        "task": None if task is None else {"id": task.id, "machine": task.machine_ref},
        "skill_paths": local_skill_files(),
        "versions": versions(),
    }
    with detached(ctx, task.episode if task is not None else None):
        payload = dumps(state, [ctx.model, ctx.data])
    return write_snapshot(path, header, payload)


def read_session(path: Path, loaded: LoadedScenario) -> tuple[SessionState, dict[str, Any]]:
    """Read back a session snapshot for the session of `loaded`.

    Raises:
        SnapshotError: Not a session snapshot, not signed with this user's key, of another
            scenario (or its file changed since), or written by another version.
    """
    snap = read_snapshot(path)
    header = snap.header
    if header.get("kind") != "session":
        raise SnapshotError(f"{path}: a snapshot of a {header.get('kind')!r}, not of a session")
    if header.get("scenario_sha256") != file_digest(loaded.path):
        raise SnapshotError(
            f"{path}: a snapshot of scenario {header.get('scenario')!r} "
            f"({header.get('scenario_file')}), not of this session's {loaded.name!r} "
            f"({loaded.path}) as it is now"
        )
    check_versions(snap)
    state = loads(snap.payload)
    if not isinstance(state, SessionState):
        raise SnapshotError(f"{path}: the payload is a {type(state).__name__}, not a session")
    return state, header
