"""What a batch runs: scenario, overrides, seeds, backend, workers, output directory."""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

__all__ = [
    "DEFAULT_MAX_WALL_S",
    "BackendName",
    "BatchConfig",
    "RecordMode",
    "default_workers",
    "portable_ref",
]

BackendName = Literal["local", "ray"]
"""Where episodes run: `local` worker processes or `ray` tasks."""

RecordMode = Literal["failures", "all", "none"]
"""Which episodes leave a Rerun recording in `DIR/episodes/seed_<S>.rrd`."""


DEFAULT_MAX_WALL_S = 600.0
"""Default wall-clock limit of one batch episode [s]: generous (pick_place takes ~2 s)."""


def default_workers() -> int:
    """The number of cores this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def portable_ref(ref: str) -> str:
    """The scenario reference workers and printed commands use.

    A file becomes its absolute path (so it does not depend on the working directory); a
    bundled name stays a name (so every machine of a cluster resolves its own copy).
    """
    path = Path(ref)
    return str(path.resolve()) if path.is_file() else ref


@dataclass(frozen=True)
class BatchConfig:
    """One `orchestrator batch` invocation.

    Attributes:
        scenario: Scenario file or bundled name, as the user gave it.
        episodes: Number of episodes; episode i runs seed `seed_base + i`.
        out_dir: Where `results.jsonl`, `summary.json` and `episodes/` go.
        seed_base: Seed of the first episode.
        workers: Worker processes (local) or CPUs of a local Ray; None: every core.
        backend: `local` or `ray`.
        address: Ray cluster address (None: `$RAY_ADDRESS`, else a local Ray).
        resume: Skip seeds already in `results.jsonl` instead of refusing to overwrite it.
        overrides: `--set KEY=VALUE` texts, applied to the scenario in every worker.
        record: Which episodes to record; None means `failures` if recording is available.
        max_wall_s: Wall-clock limit of one episode [s]: past it the episode is stopped and
            recorded as `error` (its worker is killed if it does not stop within a grace).
        allow_paths: Directories the scenario's includes may name (`--allow-path`).
        snapshot_on_failure: Keep, for each episode that does not succeed, the snapshot at
            its last state entry before the failure (`DIR/snapshots/seed_<S>.snap`).
        skill_paths: `--skills` folders or files (absolute), registered in every worker
            before it loads the scenario, as `run --skills` does in its process.
    """

    scenario: str
    episodes: int
    out_dir: Path
    seed_base: int = 0
    workers: int | None = None
    backend: BackendName = "local"
    address: str | None = None
    resume: bool = False
    overrides: tuple[str, ...] = field(default_factory=tuple)
    record: RecordMode | None = None
    max_wall_s: float | None = DEFAULT_MAX_WALL_S
    allow_paths: tuple[str, ...] = ()
    snapshot_on_failure: bool = False
    skill_paths: tuple[str, ...] = ()

    @property
    def seeds(self) -> range:
        """The seeds of this batch, in order."""
        return range(self.seed_base, self.seed_base + self.episodes)

    @property
    def n_workers(self) -> int:
        """Workers to use: the configured number, or every core."""
        return self.workers if self.workers is not None else default_workers()
