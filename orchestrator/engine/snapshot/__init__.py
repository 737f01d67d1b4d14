"""Snapshots of a running episode: break at a state, write the run's state to a file as data,
resume it bit for bit, or change one thing first (docs/time-travel.md)."""

from .breaks import ANY_GUARD, BreakPoint, break_points, state_paths
from .errors import SnapshotError
from .run_snapshot import RunSnapshot, capture_run, load_run, write_run
from .snapfile import SnapshotFile, read_snapshot, trust, write_snapshot
from .stops import EntryLog, Stop, find_stop, last_entry_stop, run_to
from .timetravel import Broken, break_run, default_snapshot_path, local_skill_files, open_run

__all__ = [
    "ANY_GUARD",
    "BreakPoint",
    "Broken",
    "EntryLog",
    "RunSnapshot",
    "SnapshotError",
    "SnapshotFile",
    "Stop",
    "break_points",
    "break_run",
    "capture_run",
    "default_snapshot_path",
    "find_stop",
    "last_entry_stop",
    "load_run",
    "local_skill_files",
    "open_run",
    "read_snapshot",
    "run_to",
    "state_paths",
    "trust",
    "write_run",
    "write_snapshot",
]
