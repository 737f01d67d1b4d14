"""`DIR/summary.json`: counts, success rate with its 95 % interval, and how to re-run a failure."""

from __future__ import annotations

import shlex
from collections import Counter
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from pydantic import BaseModel, Field

from .memory import MemoryStats, memory_stats
from .stats import percentile, wilson_interval
from .task import ERROR

__all__ = [
    "SUMMARY",
    "BatchSummary",
    "CycleTimeStats",
    "SortingStats",
    "rerun_command",
    "summarize",
]

SUMMARY = "summary.json"


class CycleTimeStats(BaseModel):
    """Cycle time of the succeeded episodes [s]: when the machine reached its final state."""

    p50: float
    p90: float
    p99: float
    mean: float
    min: float
    max: float


class SortingStats(BaseModel):
    """Parcels over the episodes of a sorting batch (each episode's task log counts)."""

    parcels: int = Field(description="Parcels in the episodes that ran (errors excluded).")
    sorted: int
    missorted: int
    dropped: int
    rejected: int
    unsorted: int
    sort_rate: float = Field(description="sorted / parcels.")
    sort_rate_ci95: tuple[float, float] = Field(description="95 % Wilson score interval.")
    parcels_per_hour: float = Field(
        description="Sorted parcels per simulated hour: all sorted over all simulated time."
    )


def _sorting(lines: list[dict[str, Any]]) -> SortingStats | None:
    with_parcels = [ln for ln in lines if "parcels" in ln.get("metrics", {})]
    if not with_parcels:
        return None
    total = {
        k: sum(int(ln["metrics"].get(k, 0)) for ln in with_parcels)
        for k in ("parcels", "sorted", "missorted", "dropped", "rejected", "unsorted")
    }
    n, ok = total["parcels"], total["sorted"]
    sim = sum(float(ln.get("sim_time", 0.0)) for ln in with_parcels)
    return SortingStats(
        **total,
        sort_rate=round(ok / n, 6) if n else 0.0,
        sort_rate_ci95=tuple(round(v, 6) for v in wilson_interval(ok, n)),  # type: ignore[arg-type]
        parcels_per_hour=round(ok / sim * 3600.0, 1) if sim > 0 else 0.0,
    )


class BatchSummary(BaseModel):
    """What a batch found. Counts and rates cover the requested seeds, including episodes a
    resumed batch found already finished; wall time and throughput cover this invocation."""

    scenario: str = Field(description="The scenario's name.")
    scenario_ref: str = Field(description="The scenario file or bundled name the batch ran.")
    overrides: list[str]
    seed_base: int
    backend: str
    workers: int
    episodes: int = Field(description="Episodes with a result line.")
    succeeded: int
    failed: int
    aborted: int
    errors: int = Field(description="Episodes that raised or whose worker died.")
    success_rate: float = Field(description="succeeded / episodes.")
    success_rate_ci95: tuple[float, float] = Field(description="95 % Wilson score interval.")
    abort_reasons: dict[str, int] = Field(description="Aborted episodes by the guard that fired.")
    cycle_time_s: CycleTimeStats | None = Field(description="Over succeeded episodes [s].")
    wall_time_s: float = Field(description="Wall time of this invocation [s].")
    episodes_run: int = Field(description="Episodes run by this invocation (not resumed).")
    episodes_per_s: float = Field(description="episodes_run / wall_time_s [1/s].")
    failing_seeds: list[int] = Field(description="Seeds that did not succeed, in order.")
    rerun_command: str | None = Field(
        description="Re-runs the first failing seed alone (from its snapshot, at the last "
        "state entry before the failure, with --snapshot-on-failure)."
    )
    snapshot_errors: dict[str, str] = Field(
        default_factory=dict,
        description="With --snapshot-on-failure: failing seeds whose snapshot could not be "
        "written, and why (their rerun runs from t = 0).",
    )
    results: str = Field(description="Path of results.jsonl.")
    sorting: SortingStats | None = Field(
        default=None, description="Parcel counts of a batch whose scenario has parcels."
    )
    memory: MemoryStats | None = Field(
        default=None,
        description="Each worker's RSS at the end of its first and its last episode [MB].",
    )

    def to_json_dict(self) -> dict[str, Any]:
        """The summary as plain JSON types (what summary.json holds)."""
        return self.model_dump(mode="json")


def rerun_command(
    ref: str,
    overrides: Iterable[str],
    seed: int,
    rrd: Path | None = None,
    snapshot: Path | None = None,
    allow_paths: Iterable[str] = (),
    skill_paths: Iterable[str] = (),
) -> str:
    """The shell command that runs one episode of the batch again, on its own: `run` prepares
    it as the batch's worker did (engine/prepare.py), so it reproduces the episode.

    Args:
        ref: Scenario file or bundled name.
        overrides: The batch's `--set` texts.
        seed: The episode's seed.
        rrd: Where `run` should save a Rerun recording, if recording is available.
        snapshot: The episode's snapshot (`--snapshot-on-failure`): the command resumes it,
            at the last state entry before the failure, instead of running from the start.
        allow_paths: The batch's `--allow-path` directories (absolute): the scenario's files
            load from them again.
        skill_paths: The batch's `--skills` paths (the command passes them on).
    """
    if snapshot is not None:  # the scenario named: its own code folders are imported
        parts = ["orchestrator", "run", ref, "--from", str(snapshot)]
    else:
        parts = ["orchestrator", "run", ref, "--seed", str(seed)]
        for text in overrides:
            parts += ["--set", text]
        for path in allow_paths:
            parts += ["--allow-path", path]
    for path in skill_paths:
        parts += ["--skills", str(path)]
    if rrd is not None:
        parts += ["--rrd", str(rrd)]
    return shlex.join(parts)


def summarize(
    lines: Iterable[dict[str, Any]],
    *,
    scenario: str,
    scenario_ref: str,
    overrides: Iterable[str],
    seed_base: int,
    backend: str,
    workers: int,
    wall_time_s: float,
    episodes_run: int,
    results: Path,
    rrd_dir: Path | None,
    allow_paths: Iterable[str] = (),
    skill_paths: Iterable[str] = (),
) -> BatchSummary:
    """Summarize result lines (one per seed).

    Args:
        lines: The batch's result lines.
        scenario: The scenario's name.
        scenario_ref: What to put in the re-run command (a bundled name or a path).
        overrides: The batch's `--set` texts.
        seed_base: The first seed.
        backend: `local` or `ray`.
        workers: Number of workers.
        wall_time_s: Wall time of this invocation [s].
        episodes_run: Episodes this invocation ran.
        results: Path of results.jsonl.
        rrd_dir: The batch directory when its episodes are recorded (the re-run command then
            saves `--rrd DIR/episodes/seed_<S>.rerun.rrd`, beside the episode's), else None.
        allow_paths: The batch's `--allow-path` directories (in the re-run command).
        skill_paths: The batch's `--skills` paths (for the re-run command).
    """
    lines = sorted(lines, key=lambda ln: ln["seed"])
    overrides = list(overrides)
    outcomes = Counter(ln["outcome"] for ln in lines)
    n = len(lines)
    ok = outcomes["succeeded"]
    aborts = Counter(
        (ln.get("reason") or {}).get("guard", "safe stop")
        for ln in lines
        if ln["outcome"] == "aborted"
    )
    cycle = [
        float(ln["metrics"]["cycle_time"])
        for ln in lines
        if ln["outcome"] == "succeeded" and ln.get("metrics", {}).get("cycle_time") is not None
    ]
    failing = [int(ln["seed"]) for ln in lines if ln["outcome"] != "succeeded"]
    command = None
    if failing:
        seed = failing[0]
        rrd = (
            rrd_dir / "episodes" / f"seed_{seed}.rerun.rrd" if rrd_dir is not None else None
        )  # beside the saved recording, never over it
        line = next(ln for ln in lines if int(ln["seed"]) == seed)
        snapshot = results.parent / line["snapshot"] if line.get("snapshot") else None
        command = rerun_command(
            scenario_ref, overrides, seed, rrd, snapshot, allow_paths, skill_paths
        )
    return BatchSummary(
        scenario=scenario,
        scenario_ref=scenario_ref,
        overrides=overrides,
        seed_base=seed_base,
        backend=backend,
        workers=workers,
        episodes=n,
        succeeded=ok,
        failed=outcomes["failed"],
        aborted=outcomes["aborted"],
        errors=outcomes[ERROR],
        success_rate=round(ok / n, 6) if n else 0.0,
        success_rate_ci95=tuple(round(v, 6) for v in wilson_interval(ok, n)),  # type: ignore[arg-type]
        abort_reasons=dict(sorted(aborts.items())),
        cycle_time_s=_cycle_stats(cycle),
        wall_time_s=round(wall_time_s, 3),
        episodes_run=episodes_run,
        episodes_per_s=round(episodes_run / wall_time_s, 4) if wall_time_s > 0 else 0.0,
        failing_seeds=failing,
        rerun_command=command,
        snapshot_errors={
            str(ln["seed"]): str(ln["snapshot_error"]) for ln in lines if ln.get("snapshot_error")
        },
        results=str(results),
        sorting=_sorting(lines),
        memory=memory_stats(lines),
    )


def _cycle_stats(values: list[float]) -> CycleTimeStats | None:
    if not values:
        return None
    return CycleTimeStats(
        p50=round(percentile(values, 50), 4),
        p90=round(percentile(values, 90), 4),
        p99=round(percentile(values, 99), 4),
        mean=round(sum(values) / len(values), 4),
        min=round(min(values), 4),
        max=round(max(values), 4),
    )
