"""The human-readable end of a batch: the summary as a short table."""

from __future__ import annotations

from rich.console import Console
from rich.table import Table

from .summary import BatchSummary

__all__ = ["print_summary"]

_MAX_SEEDS_SHOWN = 20


def print_summary(summary: BatchSummary, console: Console) -> None:
    """Print counts, the success rate with its 95 % interval, timing and failing seeds."""
    s = summary
    lo, hi = s.success_rate_ci95
    style = "green" if s.succeeded == s.episodes else "yellow"
    console.print(
        f"[bold]{s.scenario}[/]: {s.episodes} episodes, [{style}]{s.success_rate:.1%} succeeded[/]"
        f" (95 % CI {lo:.1%} - {hi:.1%})"
    )
    table = Table(box=None, pad_edge=False, show_header=False)
    table.add_row("succeeded", str(s.succeeded))
    table.add_row("failed", str(s.failed))
    table.add_row("aborted", str(s.aborted) + _reasons(s.abort_reasons))
    table.add_row("errors", str(s.errors))
    if s.cycle_time_s is not None:
        c = s.cycle_time_s
        table.add_row("cycle time", f"p50 {c.p50:.2f} s, p90 {c.p90:.2f} s, p99 {c.p99:.2f} s")
    table.add_row(
        "throughput",
        f"{s.episodes_run} episodes in {s.wall_time_s:.1f} s = {s.episodes_per_s:.2f} episodes/s "
        f"({s.backend}, {s.workers} workers)",
    )
    if s.memory is not None:
        m = s.memory
        table.add_row(
            "worker memory",
            f"RSS {min(w.rss_start_mb for w in m.workers):.0f} -> "
            f"{max(w.rss_end_mb for w in m.workers):.0f} MB, growth at most "
            f"{m.max_growth_mb:+.1f} MB over {max(w.episodes for w in m.workers)} episodes",
        )
    console.print(table)
    if s.failing_seeds:
        shown = ", ".join(map(str, s.failing_seeds[:_MAX_SEEDS_SHOWN]))
        more = len(s.failing_seeds) - _MAX_SEEDS_SHOWN
        console.print(f"failing seeds: {shown}" + (f" and {more} more" if more > 0 else ""))
        console.print(f"re-run one:    {s.rerun_command}", markup=False, soft_wrap=True)
    if s.snapshot_errors:
        seed, why = next(iter(s.snapshot_errors.items()))
        console.print(
            f"no snapshot:   {len(s.snapshot_errors)} failing seeds (seed {seed}: {why}); "
            "their reruns start from t = 0",
            markup=False,
            soft_wrap=True,
        )
    console.print(f"results:       {s.results}", markup=False, soft_wrap=True)


def _reasons(reasons: dict[str, int]) -> str:
    if not reasons:
        return ""
    return " (" + ", ".join(f"{guard} {n}" for guard, n in reasons.items()) + ")"
