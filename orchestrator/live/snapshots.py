"""A live session's snapshots: the world it keeps, as data.

`snapshot [NAME]` writes `<folder>/<NAME>.snap` at the start of the next control tick: the
world's state as data (engine/snapshot/world_state.py: MuJoCo's integration state, the random
generators, the controller's, the IK's and the context's plain data) and, in the header, the
task that was running, if any. The loop only captures it; a writer off the loop serializes,
compresses and writes it, under a per-session cap on count and bytes (live/snapshot_writer.py).
`restore NAME` builds a world from the session's scenario and seed the way the session built
its own and puts the recorded state on it; the arm then holds where it is. The running task
and the queue are dropped (their clients are told); the task of the snapshot is not resumed (a
session snapshot holds the world, not a task's code: the `restore` event says which task it
was). A latched state (e-stop, error) never comes from a snapshot: the latch is the session's
own, a restore neither sets nor clears it, and is refused while it holds, when it arrives and
again when it is applied. Files are written and read as `orchestrator run`'s are
(engine/snapshot/snapfile.py: bounded reads, data only, signed with the key of the user the
session runs as, refused if another version or another scenario wrote it). Names are plain
(letters, digits, `_`, `-`, `.`; no path): a client never names a file outside the session's
folder.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from ..engine.blackboard import Blackboard
from ..engine.cell import Cell
from ..engine.context import Context
from ..engine.safety_stop import SafetyStop
from ..engine.snapshot import SnapshotError, local_skill_files, read_snapshot, write_snapshot
from ..engine.snapshot.run_snapshot import check_any_header, check_versions, file_digest
from ..engine.snapshot.snapfile import pack
from ..engine.snapshot.versions import versions
from ..engine.snapshot.world_state import apply_world, capture_world
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
    """Write `state`'s world as a signed snapshot of data; returns its size [bytes]."""
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
    tree, arrays = capture_world(ctx)
    arrays["world"] = np.frombuffer(json.dumps(tree, allow_nan=False).encode(), np.uint8)
    return write_snapshot(path, header, pack(arrays))


def read_session(path: Path, loaded: LoadedScenario) -> tuple[SessionState, dict[str, Any]]:
    """Read back a session snapshot for the session of `loaded`: a world built from the
    scenario and the snapshot's seed, the recorded state put on it (bounded reads, data only).

    Raises:
        SnapshotError: Not a session snapshot, not signed with this user's key, of another
            scenario (or its file changed since), written by another version, or broken.
    """
    snap = read_snapshot(path)
    header = snap.header
    if header.get("kind") != "session":
        kind = header.get("kind")
        what = f"a snapshot of a {kind[:40]!r}" if isinstance(kind, str) else "no kind"
        raise SnapshotError(f"{path}: {what}, not of a session")
    check_any_header(path, header)
    if header.get("scenario_sha256") != file_digest(loaded.path):
        raise SnapshotError(
            f"{path}: a snapshot of scenario {str(header.get('scenario'))[:80]!r} "
            f"({str(header.get('scenario_file'))[:200]}), not of this session's {loaded.name!r} "
            f"({loaded.path}) as it is now"
        )
    check_versions(snap)
    seed = header["seed"]
    arrays = snap.arrays()
    raw = arrays.pop("world", None)
    if raw is None or raw.dtype != np.uint8 or raw.ndim != 1:
        raise SnapshotError(f"{path}: the payload holds no world")
    try:
        tree = json.loads(raw.tobytes())
    except (ValueError, UnicodeDecodeError, RecursionError) as exc:
        raise SnapshotError(f"{path}: broken snapshot world: {str(exc)[:200]}") from None
    cell = Cell.build(loaded.scenario, seed)  # as the session built its own
    world, controller, loop = cell.world, cell.controller, cell.loop
    ctx = Context(cell, Blackboard({}))
    loop.bind(ctx)
    mujoco.mj_forward(world.model, world.data)
    apply_world(tree, arrays, ctx, str(path))
    controller.hold(ctx.q)  # no task comes back: the arm holds where it is
    state = SessionState(world, ctx, controller, loop, None, None, Blocked(loaded, ctx))
    return state, header
