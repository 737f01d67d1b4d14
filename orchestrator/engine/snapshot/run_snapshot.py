"""A snapshot of `orchestrator run`: the whole `RunState` between two control ticks.

What the run depends on from here is exactly what `RunState` reaches, and the snapshot
pickles all of it (pickler.py): MuJoCo's model and data (the model too: a conveyor reshapes
parcels and a tissue probe moves static bodies during a run), the controller (its pinocchio
model and data, its setpoints), the IK (mink's configuration, the QP's cached rows, the joint
limiter), the encoders and every noise generator (numpy Generators pickle their exact state),
the blackboard, the executor (the active state at every level, inside nested machines and
parallel states, every running skill with its profile, retry counters, timers, the
transitions and the task log), the fault injector's queue, the scenario, the seed.

What is not the run's is left out and given back on restore: the observers (a recorder is
this process's output) and whatever listens to the executor from outside (`entry_listeners`).
"""

from __future__ import annotations

import hashlib
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..context import Context
from ..episode import Episode
from ..runner import RunState
from .pickler import SnapshotError, dumps, loads
from .snapfile import SnapshotFile, read_snapshot, write_snapshot
from .versions import differences, versions

__all__ = [
    "RunSnapshot",
    "capture_run",
    "check_versions",
    "detached",
    "file_digest",
    "load_run",
    "write_run",
]


@dataclass(frozen=True)
class RunSnapshot:
    """A run snapshot read back.

    Attributes:
        run: The run, ready to continue (`engine.runner.drive`).
        header: The file's header (scenario, seed, time, state, break point, versions).
        path: The file.
        load_s: Wall time it took to verify, decompress and unpickle [s].
    """

    run: RunState
    header: dict[str, Any]
    path: Path
    load_s: float


def file_digest(path: Path) -> str:
    """SHA-256 of a file's bytes (the scenario a snapshot was taken of)."""
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


@contextmanager
def detached(ctx: Context, episode: Episode | None) -> Iterator[None]:
    """Within: `episode`'s observers, their listeners on `ctx` and the executor's
    `entry_listeners` are taken off (they are this process's, not the run's); put back after."""
    observers = episode.observers if episode is not None else []
    own = {id(o) for o in observers}
    listeners = ctx.listeners
    entry = episode.executor.entry_listeners if episode is not None else []
    try:
        if episode is not None:
            episode.observers = []
            episode.loop.set_observers([])
            episode.executor.entry_listeners = []
        ctx.listeners = [f for f in listeners if id(getattr(f, "__self__", None)) not in own]
        yield
    finally:
        ctx.listeners = listeners
        if episode is not None:
            episode.observers = observers
            episode.loop.set_observers(observers)
            episode.executor.entry_listeners = entry


def capture_run(run: RunState) -> bytes:
    """Pickle `run` (pickler.py), without what is not the run's (see the module docstring);
    the run itself is left as it was and may continue."""
    with detached(run.ctx, run.episode):
        return dumps(run, [run.ctx.model, run.ctx.data])


def run_header(run: RunState, stop: dict[str, Any], skill_paths: list[str]) -> dict[str, Any]:
    """The header of a run snapshot: what it is of and where it stopped (readable without
    unpickling: `orchestrator snapshot show`)."""
    ctx, loaded = run.ctx, run.loaded
    return {
        "kind": "run",
        "scenario": loaded.name,
        "scenario_file": str(loaded.path),
        "scenario_sha256": file_digest(loaded.path),
        "seed": run.seed,
        "t": round(ctx.t, 6),
        "tick": ctx.tick,
        "state": run.executor.leaf if run.started else None,
        "break": stop,
        "skill_paths": skill_paths,
        "versions": versions(),
    }


def write_run(path: Path, run: RunState, stop: dict[str, Any], skill_paths: list[str]) -> int:
    """Write `run` as a signed snapshot file at `path`; returns the file's size [bytes]."""
    return write_snapshot(path, run_header(run, stop, skill_paths), capture_run(run))


def check_versions(snap: SnapshotFile) -> None:
    """Refuse a snapshot written by other code or libraries (naming every difference)."""
    recorded = snap.header.get("versions")
    if not isinstance(recorded, dict):
        raise SnapshotError(f"{snap.path}: the header has no versions")
    diff = differences({str(k): str(v) for k, v in recorded.items()}, versions())
    if diff:
        raise SnapshotError(
            f"{snap.path}: written by another version, and a run resumes bit for bit only on "
            f"the code that wrote it: {'; '.join(diff)}"
        )


def load_run(path: Path, snap: SnapshotFile | None = None) -> RunSnapshot:
    """Read, verify and restore a run snapshot.

    Args:
        path: The file.
        snap: The file already read (`read_snapshot`), if it was (e.g. to register the
            scenario's skill folders its header names before the payload is unpickled).

    Raises:
        SnapshotError: Not a run snapshot, not signed with this user's key, or written by
            other code (each said with the reason).
    """
    wall0 = time.perf_counter()
    snap = snap if snap is not None else read_snapshot(path)
    if snap.header.get("kind") != "run":
        raise SnapshotError(
            f"{path}: a snapshot of a {snap.header.get('kind')!r}, not of `orchestrator run`"
        )
    check_versions(snap)
    try:
        run = loads(snap.payload)
    except Exception as exc:  # signed by this user and of this version: a bug, said plainly
        raise SnapshotError(f"{path}: the snapshot does not restore: {exc!r}") from None
    if not isinstance(run, RunState):
        raise SnapshotError(f"{path}: the payload is a {type(run).__name__}, not a run")
    return RunSnapshot(run, snap.header, Path(path), time.perf_counter() - wall0)
