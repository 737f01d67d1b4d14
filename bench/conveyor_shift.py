"""A long conveyor shift in one episode: sort rate, memory and throughput.

Runs `sorting_conveyor` with `--set parcels=N` as one episode (exactly what `orchestrator run
sorting_conveyor --set parcels=N --json` runs) with an observer that reads this process's
resident set size (RSS, /proc/self/status) as parcels are fed: at parcel `--rss-from`
(default 100), every 100 parcels, and at the end. Prints one JSON object: the task log's
counts, RSS at those parcels and its growth from `--rss-from` to the end [MB], parcels per
simulated hour, simulated, wall and CPU time. The progress (parcels fed, sorted, RSS) goes to
stderr every 25 parcels.

    python bench/conveyor_shift.py --parcels 1000 --seed 0 --out /tmp/shift1000.json
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import Any

from orchestrator.batch.memory import rss_mb
from orchestrator.engine.runner import run_episode
from orchestrator.language.load import load_scenario


class ShiftMemory:
    """Observer: RSS at chosen parcel counts (read once per control tick: one int compare)."""

    def __init__(self, rss_from: int, every: int = 100, progress_every: int = 25) -> None:
        self.rss_from, self.every, self.progress_every = rss_from, every, progress_every
        self.rss_at: dict[str, float] = {}
        self._seen = 0
        self._t0 = time.process_time()

    def on_start(self, ctx, executor) -> None:
        self.rss_at["start"] = round(rss_mb(), 1)

    def on_tick(self, ctx, executor) -> None:
        belt = ctx.world.conveyor
        if belt is None or belt.fed == self._seen:
            return
        self._seen = belt.fed
        if belt.fed == self.rss_from or belt.fed % self.every == 0:
            self.rss_at[str(belt.fed)] = round(rss_mb(), 1)
        if belt.fed % self.progress_every == 0:
            done = sum(1 for e in ctx.tasks.entries.values() if e.outcome == "sorted")
            print(
                f"fed {belt.fed}/{belt.c.parcels}, sorted {done} (judged so far), "
                f"sim {ctx.t:.0f} s, cpu {time.process_time() - self._t0:.0f} s, "
                f"RSS {rss_mb():.1f} MB",
                file=sys.stderr,
                flush=True,
            )

    def on_end(self, ctx, executor, result) -> None:
        self.rss_at["end"] = round(rss_mb(), 1)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--parcels", type=int, default=1000)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--rss-from", type=int, default=100, help="parcel to measure growth from")
    parser.add_argument("--out", type=Path, help="also write the run's full JSON here")
    args = parser.parse_args()
    loaded = load_scenario("sorting_conveyor", [f"parcels={args.parcels}"])
    memory = ShiftMemory(args.rss_from)
    cpu0, wall0 = time.process_time(), time.perf_counter()
    result = run_episode(loaded, args.seed, [memory])
    cpu, wall = time.process_time() - cpu0, time.perf_counter() - wall0
    m = result.metrics
    line = result.to_json_dict()
    if args.out is not None:
        args.out.write_text(json.dumps(line) + "\n")
    base = memory.rss_at.get(str(args.rss_from))
    report: dict[str, Any] = {
        "parcels": args.parcels,
        "seed": args.seed,
        "outcome": result.outcome,
        "final_state": result.final_state,
        "counts": {
            k: m.get(k)
            for k in ("parcels", "sorted", "missorted", "dropped", "rejected", "unsorted")
        },
        "sort_rate": round(m["sorted"] / m["parcels"], 5) if m.get("parcels") else None,
        "parcels_fed": m.get("parcels_fed"),
        "parcels_per_hour": m.get("parcels_per_hour"),
        "parcel_cycle_s": m.get("parcel_cycle_s"),
        "tasks_listed": len(line.get("tasks") or []),
        "rss_mb_at": memory.rss_at,
        "rss_growth_mb": None if base is None else round(memory.rss_at["end"] - base, 1),
        "sim_time_s": result.sim_time,
        "wall_s": round(wall, 1),
        "cpu_s": round(cpu, 1),
        "real_time_factor_cpu": round(result.sim_time / cpu, 2) if cpu > 0 else None,
        "max_wrist_force_n": m.get("max_wrist_force_n"),
    }
    print(json.dumps(report, indent=2))


if __name__ == "__main__":
    main()
