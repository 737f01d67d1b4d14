"""Break, snapshot, resume: the steps `orchestrator run --break/--from` and batches take.

`break_run` runs an episode to a break point and writes its snapshot; `open_run` reads one
back (checked: signature, header, versions, the scenario it is of; the run rebuilt from the
scenario and checked against the recorded state) and applies `--set` values;
`engine.runner.drive` continues it. The resumed run's result is the uninterrupted run's, bit
for bit, but for its wall time (tests/test_snapshot.py, bench/snapshot_identity.py).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ...language.bundled import bundled_folder
from ...language.entries import entry_file
from ...language.load import check_blackboard_sets
from ...language.yamlio import load_yaml
from ..result import RunResult
from ..runner import RunState
from .breaks import BreakPoint
from .errors import SnapshotError
from .run_snapshot import RunSnapshot, check_header, file_digest, load_run, write_run
from .snapfile import read_snapshot
from .stops import Stop, find_stop, run_to
from .versions import local_files

__all__ = [
    "Broken",
    "break_run",
    "default_snapshot_path",
    "local_skill_files",
    "open_run",
]


@dataclass(frozen=True)
class Broken:
    """A run stopped at a break point, its snapshot written.

    Attributes:
        path: The snapshot file.
        stop: Where it stopped and why.
        run: The run as it was written (stopped there).
        size: The file's size [bytes].
        write_s: Wall time it took to record, compress, sign and write it [s].
    """

    path: Path
    stop: Stop
    run: RunState
    size: int
    write_s: float

    def to_json_dict(self) -> dict[str, Any]:
        """What `run --break --json` prints."""
        ctx = self.run.ctx
        return {
            "scenario": self.run.loaded.name,
            "seed": self.run.seed,
            "snapshot": str(self.path),
            "break": self.stop.header(),
            "t": round(ctx.t, 6),
            "tick": ctx.tick,
            "state": self.run.executor.leaf if self.run.started else None,
            "bytes": self.size,
            "write_s": round(self.write_s, 4),
        }


def local_skill_files() -> list[str]:
    """The user's own skill and check modules imported now (a scenario's `skills:`,
    `--skills`): a resumed run must have them imported too (the snapshot names them; it never
    imports anything itself)."""
    return local_files()


def default_snapshot_path(run: RunState, stop: Stop) -> Path:
    """`<scenario>-seed<S>-tick<N>.snap` in the working directory."""
    return Path(f"{run.loaded.name}-seed{run.seed}-tick{stop.tick}.snap")


def break_run(
    make_run: Callable[[], RunState],
    points: Sequence[BreakPoint],
    out: Path | None = None,
) -> Broken | RunResult:
    """Run to the first break point and write the snapshot there.

    Args:
        make_run: Makes the run from its start (a fresh world, or a snapshot read back):
            called twice for a state or guard break point (`stops.py`).
        points: The break points.
        out: The snapshot file (None: `default_snapshot_path`).

    Returns:
        The snapshot written, or the run's result if it ended without reaching a break point.
    """
    run = make_run()
    stop, result = find_stop(run, points)
    if stop is None:
        assert result is not None
        return result
    if not stop.reached(run):  # a state or guard: run again, to the start of that tick
        run = make_run()
        if not run_to(run, stop):
            raise SnapshotError(
                f"the run did not come back to control tick {stop.tick} ({stop.reason}) when "
                "run again: it is not deterministic, and a snapshot could not resume it"
            )
    path = out if out is not None else default_snapshot_path(run, stop)
    wall0 = time.perf_counter()
    size = write_run(path, run, stop.header(), local_skill_files())
    return Broken(Path(path), stop, run, size, time.perf_counter() - wall0)


def open_run(
    path: Path,
    scenario: str | None = None,
    seed: int | None = None,
    sets: Sequence[str] = (),
) -> RunSnapshot:
    """Read a run snapshot back, ready to continue, with `sets` applied.

    Args:
        path: The snapshot file.
        scenario: The scenario the user named with it (None: none): it must be the one the
            snapshot was taken of, unchanged since.
        seed: The seed the user named with it (None: none): it must be the snapshot's.
        sets: `--set KEY=VALUE`: blackboard keys of the machine, checked like any `--set`.

    Raises:
        SnapshotError: The file is refused (not a snapshot, not signed with this user's key,
            another version, another scenario or seed).
        ConfigError: A `--set` is refused (each problem located at `<--set>`).
    """
    snap = read_snapshot(path)
    header = check_header(snap)
    _check_scenario(snap.path, header, scenario)
    if seed is not None and seed != header["seed"]:
        raise SnapshotError(
            f"{path}: a snapshot of seed {header['seed']}, not seed {seed}: it resumes "
            "the run it was taken of (leave --seed out)"
        )
    _check_code(snap.path, header, scenario)
    opened = load_run(Path(path), snap)
    values = check_blackboard_sets(opened.run.loaded, list(sets))
    blackboard = opened.run.ctx.blackboard
    for key, value in values.items():
        blackboard[key] = value
    return opened


def _check_code(path: Path, header: dict[str, Any], scenario: str | None) -> None:
    """A scenario outside the bundled ones that imports code (`skills:` folders) is rebuilt
    only when the user named it: a snapshot never decides which code runs."""
    ref = Path(header["recipe"]["ref"])
    if scenario is not None or any(
        ref.is_relative_to(bundled_folder(kind).resolve()) for kind in ("scenarios", "machines")
    ):
        return
    try:
        skills = load_yaml(ref).data
    except Exception:  # noqa: BLE001 (unreadable: load_scenario says why, with the file)
        return
    if isinstance(skills, dict) and skills.get("skills"):
        raise SnapshotError(
            f"{path}: its scenario {ref} imports code from its skills: folders, and a snapshot "
            f"never decides which code runs: name the scenario to resume it "
            f"(orchestrator run {ref} --from {path})"
        )


def _check_scenario(path: Path, header: dict[str, Any], scenario: str | None) -> None:
    if scenario is None:
        return
    name = header.get("scenario")
    found = entry_file(scenario)
    if found is None:
        raise SnapshotError(f"{path}: no scenario {scenario!r} to compare the snapshot with")
    if file_digest(found) != header.get("scenario_sha256"):
        same_name = Path(str(header.get("scenario_file", ""))).resolve() == found.resolve()
        why = (
            f"{found} changed since the snapshot was taken"
            if same_name
            else f"it is a snapshot of scenario {name!r} ({header.get('scenario_file')}), "
            f"not of {scenario!r}"
        )
        raise SnapshotError(f"{path}: {why}: a snapshot resumes the run it was taken of")
