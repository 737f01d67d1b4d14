"""One episode to run, and the result line of an episode that could not produce a result."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from .config import RecordMode

__all__ = ["ERROR", "NOT_WRITTEN", "EpisodeTask", "error_line", "rrd_name", "snapshot_name"]

ERROR = "error"
"""The outcome of an episode that raised, or whose worker process died."""
NOT_WRITTEN = "not_written"
"""Key of a worker's line saying a file could not be written (a full disk): the line is no
result of the episode; the batch stops and `--resume` runs that episode again."""


def rrd_name(seed: int) -> str:
    """Where the recording of `seed` goes, relative to the batch directory."""
    return f"episodes/seed_{seed}.rrd"


def snapshot_name(seed: int) -> str:
    """Where the snapshot of a failed `seed` goes, relative to the batch directory."""
    return f"snapshots/seed_{seed}.snap"


@dataclass(frozen=True)
class EpisodeTask:
    """Everything a worker needs to run one episode; small and picklable.

    Attributes:
        scenario: Scenario file (absolute path) or bundled name, loaded by the worker.
        overrides: `--set` texts applied when the worker loads the scenario.
        seed: The episode's seed.
        record: `all` records the episode; `failures` re-runs a failed or aborted episode
            with a recorder (same seed, same episode); `none` records nothing.
        out_dir: Absolute batch directory; recordings go to `out_dir/episodes/`.
        max_wall_s: Wall-clock limit of the episode [s]; past it the episode is stopped and
            recorded as `error` (None: no limit).
        allow_paths: Directories the scenario's `machine:` includes may name besides its own
            tree (`--allow-path`), absolute.
        snapshot_on_failure: An episode that does not succeed is run again to the start of
            the tick of its last state entry before the failure, and that snapshot is kept in
            `out_dir/snapshots/` (engine/snapshot).
        skill_paths: `--skills` folders or files (absolute) the worker registers first.
    """

    scenario: str
    overrides: tuple[str, ...]
    seed: int
    record: RecordMode = "none"
    out_dir: str | None = None
    max_wall_s: float | None = None
    allow_paths: tuple[str, ...] = ()
    snapshot_on_failure: bool = False
    skill_paths: tuple[str, ...] = ()

    def rrd_path(self) -> Path:
        """Absolute path of this episode's recording."""
        if self.out_dir is None:
            raise ValueError("this task has no out_dir to record into")
        return Path(self.out_dir) / rrd_name(self.seed)


def error_line(task: EpisodeTask, kind: str, message: str, traceback: str | None) -> dict[str, Any]:
    """The results.jsonl line of an episode that ended in an exception or a dead worker.

    Args:
        task: The episode.
        kind: The exception type (or `WorkerDied`).
        message: One line saying what happened.
        traceback: The formatted traceback, when there is one.
    """
    return {
        "scenario": None,
        "seed": task.seed,
        "outcome": ERROR,
        "final_state": None,
        "reason": None,
        "error": {"type": kind, "message": message, "traceback": traceback},
    }
