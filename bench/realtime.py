"""Headless real-time factor of a scenario: simulated time / wall time, per episode.

Reports the median over seeds for (a) episodes run in one process (the batch case: robot
model, meshes and IK model cached after the first episode) and (b) `orchestrator run` as a
fresh process per episode (wall_time from its JSON: world build + simulation, cold caches).

    python bench/realtime.py [--scenario pick_place] [--seeds 20] [--cli 5] [--no-reference]
    python bench/realtime.py --scenario sorting pick_place mobile_search --seeds 5 --cli 0

Also reported: the CPU time of the process over the episodes (`time.process_time`, world
build included), which on a machine shared with other work is the honest one-core figure
(wall time includes waiting), as a real-time factor and as CPU microseconds per physics step
(at 2 ms, 10x real time is 200 us). The wall factor is the run's own `wall_time` (simulation,
world build excluded).

For scale, the same process runs bench/overhead.py's hand-written pick_place loop (the same
world, plant, controller and motion generator, no framework) on the same seeds, interleaved
with the scenarios' episodes seed by seed (first on odd seeds, last on even ones) so that a
change in the machine's load hits all alike (`--no-reference` leaves it out). The table
gives each scenario's CPU per simulated second against the hand-written loop's (for
pick_place the same task, also paired by seed; for the others a reference of what the plant
and the motion generator cost by themselves), and the load average (`os.getloadavg()`) at
the start and the end: on a shared 2-core host the figures fall as it rises.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from dataclasses import dataclass, field
from typing import Any

REFERENCE = "hand-written pick_place"
"""The reference's row name (bench/overhead.py's `HandWritten`)."""


@dataclass
class Runs:
    """One scenario's in-process episodes: per episode the simulated time [s], wall time [s]
    (simulation only) and CPU time [s] (world build included), and the cycle time [s]."""

    name: str
    dt: float
    sim: list[float] = field(default_factory=list)
    wall: list[float] = field(default_factory=list)
    cpu: list[float] = field(default_factory=list)
    cycle: list[float] = field(default_factory=list)
    ok: int = 0

    def add(self, sim: float, wall: float, cpu: float, cycle: float | None, ok: bool) -> None:
        self.sim.append(sim)
        self.wall.append(wall)
        self.cpu.append(cpu)
        self.cycle.append(cycle or sim)
        self.ok += ok

    @property
    def cpu_rtf(self) -> list[float]:
        return [s / c for s, c in zip(self.sim, self.cpu, strict=True)]

    @property
    def wall_rtf(self) -> list[float]:
        return [s / w for s, w in zip(self.sim, self.wall, strict=True)]

    @property
    def us_per_step(self) -> list[float]:
        return [c / (s / self.dt) * 1e6 for s, c in zip(self.sim, self.cpu, strict=True)]

    def line(self) -> str:
        med, cpu, wall = statistics.median, self.cpu_rtf, self.wall_rtf
        return (
            f"{self.name} in-process: median RTF {med(wall):5.1f}x wall "
            f"(min {min(wall):.1f}x, max {max(wall):.1f}x), {med(cpu):5.1f}x CPU "
            f"(min {min(cpu):.1f}x, {med(self.us_per_step):.0f} us CPU per step) over "
            f"{len(cpu)} seeds, {self.ok} succeeded; median cycle_time {med(self.cycle):.2f} s "
            f"(max {max(self.cycle):.2f} s)"
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=20, help="episodes run in-process")
    parser.add_argument("--cli", type=int, default=5, help="episodes run as fresh processes")
    parser.add_argument(
        "--scenario", nargs="+", default=["pick_place"], help="bundled names or paths"
    )
    parser.add_argument(
        "--reference",
        action=argparse.BooleanOptionalAction,
        default=True,
        help="run bench/overhead.py's hand-written pick_place loop on the same seeds, "
        "interleaved, for scale",
    )
    args = parser.parse_args()
    from orchestrator.engine.runner import run_episode
    from orchestrator.language.load import load_scenario

    load0 = os.getloadavg()
    print(f"load average {_load(load0)} (1, 5, 15 min) at the start", flush=True)
    loaded = {name: load_scenario(name) for name in args.scenario}
    for scenario in loaded.values():
        run_episode(scenario, 10_000)  # warm the caches once, as a batch worker would
    reference = _reference() if args.reference else None
    if reference is not None:
        reference[1](10_000)
    runs = {name: Runs(name, scn.scenario.physics.timestep_s) for name, scn in loaded.items()}
    ref_runs = Runs(REFERENCE, reference[0]) if reference is not None else None
    for seed in range(args.seeds):  # seed by seed: load drift hits every row alike
        # the reference first on odd seeds, last on even ones (what runs before an episode
        # leaves the caches to it)
        if reference is not None and ref_runs is not None and seed % 2:
            ref_runs.add(*reference[1](seed))
        for name, scenario in loaded.items():
            cpu0 = time.process_time()
            r = run_episode(scenario, seed)
            cpu = time.process_time() - cpu0
            ok = r.outcome == "succeeded"
            runs[name].add(r.sim_time, r.wall_time, cpu, r.metrics.get("cycle_time"), ok)
        if reference is not None and ref_runs is not None and not seed % 2:
            ref_runs.add(*reference[1](seed))
    for name, row in runs.items():
        print(row.line(), flush=True)
        _cli(name, args.cli)
    if ref_runs is not None:
        print(ref_runs.line())
    load1 = os.getloadavg()
    _table([*runs.values()], ref_runs)
    if ref_runs is not None and "pick_place" in runs:  # the same task, seed by seed
        pairs = [
            (c / s) / (rc / rs)
            for s, c, rs, rc in zip(
                runs["pick_place"].sim,
                runs["pick_place"].cpu,
                ref_runs.sim,
                ref_runs.cpu,
                strict=True,
            )
        ]
        print(
            f"pick_place / hand-written pick_place, CPU per simulated second, paired by seed: "
            f"median {statistics.median(pairs):.2f} (min {min(pairs):.2f}, max {max(pairs):.2f})"
        )
    print(f"load average {_load(load0)} at the start, {_load(load1)} at the end (1, 5, 15 min)")


def _reference() -> tuple[float, Any]:
    """The hand-written loop's physics step [s] and a function running its episode of a
    seed: (simulated time, wall time of the run, CPU time with the world build, cycle time,
    success), timed as `run_episode` is above."""
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    from overhead import HandWritten  # bench/overhead.py

    from orchestrator.language.load import load_scenario

    scenario = load_scenario("pick_place").scenario

    def episode(seed: int) -> tuple[float, float, float, float | None, bool]:
        cpu0 = time.process_time()
        loop = HandWritten(scenario, seed)
        wall0 = time.perf_counter()
        ok = loop.run()
        wall = time.perf_counter() - wall0
        return loop.t, wall, time.process_time() - cpu0, loop.cycle_s, ok

    return scenario.physics.timestep_s, episode


def _cli(name: str, runs: int) -> None:
    """`orchestrator run` as a fresh process per episode (cold caches)."""
    rtf = []
    for seed in range(runs):
        out = subprocess.run(
            [sys.executable, "-m", "orchestrator.cli", "run", name, "--seed", str(seed), "--json"],
            capture_output=True,
            text=True,
            check=False,
        )
        r = json.loads(out.stdout)
        rtf.append(r["sim_time"] / r["wall_time"])
    if rtf:
        print(
            f"CLI process : median RTF {statistics.median(rtf):5.1f}x  "
            f"(min {min(rtf):.1f}x, max {max(rtf):.1f}x) over {runs} runs (cold caches)"
        )


def _table(rows: list[Runs], reference: Runs | None) -> None:
    """CPU and wall factors per scenario, and CPU per simulated second against the
    hand-written loop's (ratio of the medians; > 1: the framework's scenario costs more)."""
    med = statistics.median
    ref_cost = (
        med(c / s for s, c in zip(reference.sim, reference.cpu, strict=True)) if reference else None
    )
    print(
        "\nscenario                 CPU RTF (median, min)   CPU us/step   wall RTF   "
        "CPU per sim-s / hand-written's"
    )
    for row in [*rows, *([reference] if reference is not None else [])]:
        ratio = f"{_cost(row) / ref_cost:10.2f}" if ref_cost else "         -"
        print(
            f"{row.name:24s} {med(row.cpu_rtf):6.1f}x {min(row.cpu_rtf):6.1f}x "
            f"{med(row.us_per_step):13.0f} {med(row.wall_rtf):9.1f}x {ratio}"
        )


def _cost(row: Runs) -> float:
    """Median CPU seconds per simulated second."""
    return statistics.median(c / s for s, c in zip(row.sim, row.cpu, strict=True))


def _load(load: tuple[float, float, float]) -> str:
    return " ".join(f"{x:.2f}" for x in load)


if __name__ == "__main__":
    main()
