"""Worker memory: each worker's resident set size (RSS) per episode, and the batch's summary.

A worker is a long-lived process that runs episode after episode; memory that grows with
the number of episodes (a cache that never empties, a log kept per run) shows as RSS rising
from its first episode to its last. Each result line carries `worker`: the process id, how
many episodes that process had run, and its RSS before and after the episode [MB]; the
summary keeps, per worker, its RSS at the end of its first and of its last episode.

RSS is read from `/proc/self/status` (Linux); elsewhere the peak RSS of `resource.getrusage`
stands in for it (it never falls, so it over-reports growth, never hides it).
"""

from __future__ import annotations

import gc
import itertools
import os
import resource
import sys
from collections.abc import Iterable
from typing import Any

from pydantic import BaseModel, Field

__all__ = [
    "MemoryStats",
    "WorkerMemory",
    "memory_stats",
    "release_episode",
    "rss_mb",
    "worker_stamp",
]

_STATUS = "/proc/self/status"
_episodes_run = itertools.count(1)
"""Numbers the episodes this process runs (advanced by `worker_stamp`)."""


def rss_mb() -> float:
    """This process's resident set size now [MB] (peak RSS where /proc is missing)."""
    try:
        with open(_STATUS, encoding="ascii") as f:
            for line in f:
                if line.startswith("VmRSS:"):
                    return int(line.split()[1]) / 1024.0  # kB
    except OSError:
        pass
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return peak / (1024.0 * 1024.0) if sys.platform == "darwin" else peak / 1024.0


def release_episode() -> None:
    """Free what the episode that has just ended left in reference cycles.

    An episode's objects refer to each other in cycles (its context, executor and skills; the
    `transitions` machine and its states; the world and the views into its MjData), so
    reference counting does not free them when the episode returns: the cyclic garbage
    collector does, in a full collection, and those get rarer as the heap grows. Until then
    the episode's native memory (MuJoCo's model and data, pinocchio's, the IK's own model)
    stays resident: a worker's RSS rose ~0.6 MB per pick_place episode and 2-3 MB per
    sorting episode. Collected after every episode it stays flat.

    A full collection walks every object alive (~42 ms after a pick_place episode, most of
    them created by the imports). After the first episode what is alive is frozen
    (`gc.freeze`: never collected again; it lives as long as the worker anyway), so each
    later collection walks only the objects the episode created (~1.3 ms).
    """
    gc.collect()
    if gc.get_freeze_count() == 0:  # the first episode in this process
        gc.freeze()


def worker_stamp(rss_before_mb: float) -> dict[str, Any]:
    """The `worker` entry of the result line of an episode that has just ended in this process.

    Args:
        rss_before_mb: RSS when the episode started [MB].
    """
    return {
        "pid": os.getpid(),
        "episode": next(_episodes_run),
        "rss_before_mb": round(rss_before_mb, 1),
        "rss_mb": round(rss_mb(), 1),
    }


class WorkerMemory(BaseModel):
    """One worker process over the episodes it ran in this batch."""

    pid: int = Field(description="Process id of the worker.")
    episodes: int = Field(description="Episodes of the batch it ran.")
    rss_start_mb: float = Field(
        description="RSS at the end of its first episode [MB] (imports, the loaded scenario "
        "and one episode's working set)."
    )
    rss_end_mb: float = Field(description="RSS at the end of its last episode [MB].")
    growth_mb: float = Field(description="rss_end_mb - rss_start_mb [MB].")


class MemoryStats(BaseModel):
    """Worker memory of a batch: flat when `max_growth_mb` stays near 0 however many
    episodes ran."""

    workers: list[WorkerMemory]
    max_growth_mb: float = Field(description="The largest growth of any worker [MB].")
    max_rss_mb: float = Field(description="The largest RSS any worker reported [MB].")


def memory_stats(lines: Iterable[dict[str, Any]]) -> MemoryStats | None:
    """Per-worker RSS from the `worker` entries of result lines (None when no line has one).

    Lines are ordered per worker by the worker's own episode count, so a resumed batch or
    results written out of order still compare first with last.
    """
    by_pid: dict[int, list[dict[str, Any]]] = {}
    for line in lines:
        w = line.get("worker")
        if isinstance(w, dict) and "pid" in w and "rss_mb" in w:
            by_pid.setdefault(int(w["pid"]), []).append(w)
    if not by_pid:
        return None
    workers = []
    for pid, stamps in sorted(by_pid.items()):
        stamps.sort(key=lambda w: int(w.get("episode", 0)))
        start, end = float(stamps[0]["rss_mb"]), float(stamps[-1]["rss_mb"])
        workers.append(
            WorkerMemory(
                pid=pid,
                episodes=len(stamps),
                rss_start_mb=start,
                rss_end_mb=end,
                growth_mb=round(end - start, 1),
            )
        )
    return MemoryStats(
        workers=workers,
        max_growth_mb=max(w.growth_mb for w in workers),
        max_rss_mb=max(max(float(s["rss_mb"]) for s in st) for st in by_pid.values()),
    )
