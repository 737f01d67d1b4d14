"""A snapshot of `orchestrator run`: the run between two control ticks, as data.

The file (snapfile.py) holds a header — the scenario and how it was loaded (`recipe`: the
file, `--set`, `--fault`, `--event`, the allowed folders), the seed, the tick, the break
point, the versions — and the run's state (state.py): MuJoCo's integration state and its
model's digest, every random generator's state, the controller's and the IK's data, the
machine's active path with each running skill's and success check's `snapshot_state()`, the
blackboard, the metrics and the task log.

Reading one back rebuilds the run the normal way — the scenario loaded from its recipe, the
world built for the seed — runs it to the snapshot's tick, and checks that it holds exactly
the recorded state (every array bit for bit). A run is deterministic, so it does; a run that
does not (other code, another library, a changed machine file) is refused, naming the first
difference. Or, with `restore`, puts the recorded state into the built run (restore.py: no
step simulated). Nothing of the file is ever turned into an object, a class or a call.
"""

from __future__ import annotations

import hashlib
import json
import os
import stat
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..runner import RunState, new_run
from .data import decode, first_difference
from .errors import SnapshotError
from .machine_state import IncompleteState
from .restore import restore_run
from .snapfile import SnapshotFile, pack, read_snapshot, write_snapshot
from .state import capture, detached
from .stops import Stop, run_to
from .versions import differences, local_files, versions

__all__ = [
    "RunSnapshot",
    "capture_run",
    "check_any_header",
    "check_header",
    "check_versions",
    "detached",
    "file_digest",
    "load_run",
    "rebuild_run",
    "restore_from",
    "write_run",
]

RESTORE_ONLY = (
    "declared", "graph", "machine", "model_large", "model_small", "warnings"
)  # fmt: skip
"""Parts of the state only a restore uses (every object's data by path, with its scratch
buffers and caches): the replay's check compares the rest."""

_STATE = "state.json"
"""The array holding the state's JSON tree (UTF-8 bytes as uint8)."""


@dataclass(frozen=True)
class RunSnapshot:
    """A run snapshot read back.

    Attributes:
        run: The run, ready to continue (`engine.runner.drive`).
        header: The file's header (scenario, seed, time, state, break point, versions).
        path: The file.
        load_s: Wall time it took to read and resume it [s].
        how: `restored` (from its data), `verified` (re-run from t = 0 and checked), or
            `replayed: <why>` (a running skill's declared state was not all it held).
    """

    run: RunState
    header: dict[str, Any]
    path: Path
    load_s: float
    how: str = "verified"


def file_digest(path: Path) -> str:
    """SHA-256 of a file's bytes (the scenario a snapshot was taken of)."""
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def _bounded_digest(path: Path, limit: int = 16 << 20) -> str | None:
    """SHA-256 of a regular file of at most `limit` bytes; None for anything else (a header
    may name any path: /dev/zero is not read)."""
    try:
        with open(path, "rb") as f:
            st = os.fstat(f.fileno())
            if not stat.S_ISREG(st.st_mode) or st.st_size > limit:
                return None
            return hashlib.sha256(f.read(limit + 1)).hexdigest()
    except OSError:
        return None


def capture_run(run: RunState) -> bytes:
    """`run`'s state (state.py) as the payload of a snapshot file (an .npz archive)."""
    tree, arrays = capture(run)
    text = json.dumps(tree, sort_keys=True, allow_nan=False).encode()
    arrays[_STATE.removesuffix(".json")] = np.frombuffer(text, dtype=np.uint8)
    return pack(arrays)


def run_header(run: RunState, stop: dict[str, Any], skill_paths: list[str]) -> dict[str, Any]:
    """The header of a run snapshot: what it is of, how to rebuild it and where it stopped
    (`orchestrator snapshot show` prints it)."""
    ctx, loaded = run.ctx, run.loaded
    if not loaded.recipe:
        raise SnapshotError("cannot snapshot a run of a scenario not loaded by load_scenario")
    return {
        "kind": "run",
        "scenario": loaded.name,
        "scenario_file": str(loaded.path),
        "scenario_sha256": file_digest(loaded.path),
        "recipe": loaded.recipe,
        "seed": run.seed,
        "t": round(ctx.t, 6),
        "tick": ctx.tick,
        "state": run.executor.leaf if run.started else None,
        "at": {"tick": ctx.tick, "before_start": not run.started},
        "break": stop,
        "skill_paths": skill_paths,
        "versions": versions(),
    }


def write_run(path: Path, run: RunState, stop: dict[str, Any], skill_paths: list[str]) -> int:
    """Write `run` as a signed snapshot file at `path`; returns the file's size [bytes].

    Raises:
        SnapshotError: It cannot be written (the message says why; no file is left).
    """
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


_RUN_KEYS: dict[str, tuple[type, ...]] = {
    "scenario": (str,),
    "scenario_file": (str,),
    "scenario_sha256": (str,),
    "recipe": (dict,),
    "seed": (int,),
    "t": (int, float),
    "tick": (int,),
    "state": (str, type(None)),
    "at": (dict,),
    "break": (dict,),
    "skill_paths": (list,),
    "versions": (dict,),
}
_RECIPE_KEYS: dict[str, tuple[type, ...]] = {
    "ref": (str,),
    "overrides": (list,),
    "faults": (list,),
    "events": (list,),
    "allow_paths": (list,),
    "machine": (str, type(None)),
}


_SESSION_KEYS: dict[str, tuple[type, ...]] = {
    "session": (str,),
    "scenario": (str,),
    "scenario_file": (str,),
    "scenario_sha256": (str,),
    "seed": (int,),
    "t": (int, float),
    "tick": (int,),
    "state": (str, type(None)),
    "task": (dict, type(None)),
    "skill_paths": (list,),
    "versions": (dict,),
}


def check_any_header(path: Path, h: dict[str, Any]) -> dict[str, Any]:
    """A run's or a live session's snapshot header, each key of the type it must have.

    Raises:
        SnapshotError: Another kind, or a key missing or of another type (named).
    """
    if h.get("kind") == "session":
        _typed(path, h, _SESSION_KEYS, "")
        if isinstance(h["seed"], bool) or h["seed"] < 0:
            raise SnapshotError(f"{path}: the header's seed is negative")
        return h
    return check_header(SnapshotFile(Path(path), h, b""))


def check_header(snap: SnapshotFile) -> dict[str, Any]:
    """The header of a run snapshot, each key of the type it must have.

    Raises:
        SnapshotError: Another kind of snapshot, or a key missing or of another type (named).
    """
    h, path = snap.header, snap.path
    if h.get("kind") != "run":
        kind = h.get("kind")
        what = f"a snapshot of a {str(kind)[:40]!r}" if isinstance(kind, str) else "no kind"
        raise SnapshotError(f"{path}: {what}, not of a run")
    _typed(path, h, _RUN_KEYS, "")
    _typed(path, h["recipe"], _RECIPE_KEYS, "recipe.")
    for key in ("overrides", "faults", "events", "allow_paths"):
        if not all(isinstance(v, str) for v in h["recipe"][key]):
            raise SnapshotError(f"{path}: the header's recipe.{key} is not a list of texts")
    if not all(isinstance(v, str) for v in h["skill_paths"]):
        raise SnapshotError(f"{path}: the header's skill_paths is not a list of files")
    at = h["at"]
    tick = at.get("tick")
    if not (isinstance(tick, int) and not isinstance(tick, bool)) or not isinstance(
        at.get("before_start"), bool
    ):
        raise SnapshotError(f"{path}: the header's at has no tick and before_start")
    if isinstance(h["seed"], bool) or h["seed"] < 0 or tick < 0 or h["tick"] < 0:
        raise SnapshotError(f"{path}: the header's seed or tick is negative")
    return h


def _typed(path: Path, h: dict[str, Any], keys: dict[str, tuple[type, ...]], pre: str) -> None:
    for key, types in keys.items():
        value = h.get(key)
        if (
            key not in h
            or not isinstance(value, types)
            or (isinstance(value, bool) and bool not in types)
        ):
            want = " or ".join("null" if t is type(None) else t.__name__ for t in types)
            raise SnapshotError(f"{path}: the header's {pre}{key} is missing or not {want}")


def _recorded(snap: SnapshotFile) -> tuple[Any, dict[str, np.ndarray]]:
    """The payload's state tree, decoded (data only), and its arrays."""
    arrays = snap.arrays()
    raw = arrays.pop(_STATE.removesuffix(".json"), None)
    if raw is None or raw.dtype != np.uint8 or raw.ndim != 1:
        raise SnapshotError(f"{snap.path}: the payload holds no state")
    try:
        recorded = decode(json.loads(raw.tobytes()), arrays)
    except (ValueError, UnicodeDecodeError, RecursionError) as exc:
        raise SnapshotError(f"{snap.path}: broken snapshot state: {str(exc)[:200]}") from None
    if not isinstance(recorded, dict):
        raise SnapshotError(f"{snap.path}: broken snapshot state: not a mapping")
    return recorded, arrays


def restore_from(snap: SnapshotFile, loaded: Any) -> RunState:
    """The run of `snap` built from `loaded` (the scenario loaded from the header's recipe)
    for the seed, the recorded state put into it (restore.py): no step is simulated.

    Raises:
        SnapshotError: The payload is broken or does not fit the rebuilt run.
    """
    recorded, arrays = _recorded(snap)
    run = restore_run(loaded, snap.header["seed"], recorded, arrays, str(snap.path))
    if run.ctx.tick != snap.header["tick"]:
        raise SnapshotError(f"{snap.path}: the state is not of the header's tick")
    return run


def rebuild_run(snap: SnapshotFile, loaded: Any) -> RunState:
    """The run of `snap` rebuilt from `loaded` (the scenario loaded from the header's recipe):
    the world built for the seed, run to the snapshot's tick, checked against the recorded
    state.

    Raises:
        SnapshotError: The payload is broken, or the rebuilt run is not the recorded one.
    """
    h = snap.header
    recorded, _ = _recorded(snap)
    b, at = h["break"], h["at"]
    stop = Stop(at["tick"], at["before_start"], str(b.get("reason", "")), str(b.get("option", "")))
    run = new_run(loaded, h["seed"])
    if not run_to(run, stop):
        raise SnapshotError(
            f"{snap.path}: the run rebuilt from {h['scenario_file']} ended before control tick "
            f"{stop.tick}: it is not the run the snapshot was taken of"
        )
    tree, now_arrays = capture(run)
    now = decode(tree, now_arrays)
    for key in RESTORE_ONLY:  # scratch buffers and caches differ between two equal runs
        recorded.pop(key, None)
        now.pop(key, None)
    found = first_difference(recorded, now)
    if found is not None:
        raise SnapshotError(
            f"{snap.path}: the run rebuilt from {h['scenario_file']} for seed {h['seed']} does "
            f"not hold the recorded state at tick {stop.tick} (first difference: {found[:200]}):"
            " the scenario, a file it includes or the code changed since"
        )
    return run


def load_run(path: Path, snap: SnapshotFile | None = None, restore: bool = False) -> RunSnapshot:
    """Read a run snapshot and resume it: its scenario loaded from the header's recipe (the
    scenario's `skills:` folders are imported as a run of it imports them), the run built for
    the seed, then the episode re-run from t = 0 to the snapshot's tick and checked to hold
    the recorded state, bit for bit (`rebuild_run`). With `restore`, instead, the recorded
    state is put into the built run (`restore_from`: no step simulated; not yet the default,
    docs/time-travel.md says where it is bit for bit); a running skill whose declared state
    is not all it held, or an object the built run has no place for, is then replayed as
    without it (`how` says so).

    Raises:
        SnapshotError: Not a run snapshot, not signed with this user's key, written by other
            code, or the rebuilt run is not the recorded one (each said with the reason).
    """
    from ...exceptions import ConfigError
    from ...language.load import load_scenario

    wall0 = time.perf_counter()
    snap = snap if snap is not None else read_snapshot(path)
    h = check_header(snap)
    r = h["recipe"]
    if _bounded_digest(Path(r["ref"])) != h["scenario_sha256"]:
        raise SnapshotError(
            f"{path}: its scenario {r['ref']} changed since the snapshot was taken (or is "
            "gone): a snapshot resumes the run it was taken of"
        )
    try:
        loaded = load_scenario(
            r["ref"], r["overrides"], r["faults"], r["allow_paths"], r["events"], r["machine"]
        )
    except ConfigError as exc:
        raise SnapshotError(
            f"{path}: its scenario {r['ref']} does not load any more: {exc}"
        ) from None
    missing = sorted(set(h["skill_paths"]) - set(local_files()))
    if missing:
        raise SnapshotError(
            f"{path}: the run used skill modules not imported now: {', '.join(missing[:5])}; "
            "pass their folders with --skills (a snapshot never imports code itself)"
        )
    check_versions(snap)
    how = "restored" if restore else "verified"
    try:
        run = restore_from(snap, loaded) if restore else rebuild_run(snap, loaded)
    except IncompleteState as exc:
        how = f"replayed: {exc}"
        run = rebuild_run(snap, loaded)
    return RunSnapshot(run, h, Path(path), time.perf_counter() - wall0, how)
