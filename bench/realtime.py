"""Headless real-time factor of a scenario: simulated time / wall time, per episode.

Reports the median over seeds for (a) episodes run in one process (the batch case: robot
model, meshes and IK model cached after the first episode) and (b) `orchestrator run` as a
fresh process per episode (wall_time from its JSON: world build + simulation, cold caches).

    python bench/realtime.py [--scenario pick_place] [--seeds 20] [--cli 5]
    python bench/realtime.py --scenario mobile_search sorting pick_place --seeds 5 --cli 0

Also reported: the CPU time of the process over the episodes (`time.process_time`), which on
a machine shared with other work is the honest one-core figure (wall time includes waiting),
as a real-time factor and as CPU microseconds per 2 ms physics step (10x real time is 200 us).
Several scenarios give one line each and a table at the end.
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import time


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=20, help="episodes run in-process")
    parser.add_argument("--cli", type=int, default=5, help="episodes run as fresh processes")
    parser.add_argument(
        "--scenario", nargs="+", default=["pick_place"], help="bundled names or paths"
    )
    args = parser.parse_args()
    rows = [_scenario(name, args.seeds, args.cli) for name in args.scenario]
    if len(rows) > 1:
        print("\nscenario               CPU RTF (median, min)   CPU us per physics step (median)")
        for name, cpu_rtf, lo, us in rows:
            print(f"{name:22s} {cpu_rtf:6.1f}x {lo:6.1f}x {us:12.0f}")


def _scenario(name: str, seeds: int, cli_runs: int) -> tuple[str, float, float, float]:
    """Measure one scenario; returns (name, median CPU RTF, min CPU RTF, median CPU us/step)."""
    from orchestrator.engine.runner import run_episode
    from orchestrator.language.load import load_scenario

    loaded = load_scenario(name)
    dt = loaded.scenario.physics.timestep_s
    run_episode(loaded, 10_000)  # warm the caches once, as a batch worker would
    rtf, cpu_rtf, cycle, per_step = [], [], [], []
    for seed in range(seeds):
        cpu0 = time.process_time()
        r = run_episode(loaded, seed)
        cpu = time.process_time() - cpu0
        rtf.append(r.sim_time / r.wall_time)
        cpu_rtf.append(r.sim_time / cpu)
        per_step.append(cpu / (r.sim_time / dt) * 1e6)
        cycle.append(r.metrics["cycle_time"] or r.sim_time)
    print(
        f"{name} in-process: median RTF {statistics.median(rtf):5.1f}x wall "
        f"(min {min(rtf):.1f}x, max {max(rtf):.1f}x), {statistics.median(cpu_rtf):5.1f}x CPU "
        f"(min {min(cpu_rtf):.1f}x, {statistics.median(per_step):.0f} us CPU per step) over "
        f"{seeds} seeds; median cycle_time {statistics.median(cycle):.2f} s "
        f"(max {max(cycle):.2f} s)",
        flush=True,
    )
    cli = []
    for seed in range(cli_runs):
        out = subprocess.run(
            [
                sys.executable,
                "-m",
                "orchestrator.cli",
                "run",
                name,
                "--seed",
                str(seed),
                "--json",
            ],
            capture_output=True,
            text=True,
            check=False,
        )
        r = json.loads(out.stdout)
        cli.append(r["sim_time"] / r["wall_time"])
    if cli:
        print(
            f"CLI process : median RTF {statistics.median(cli):5.1f}x  "
            f"(min {min(cli):.1f}x, max {max(cli):.1f}x) over {cli_runs} runs (cold caches)"
        )
    return name, statistics.median(cpu_rtf), min(cpu_rtf), statistics.median(per_step)


if __name__ == "__main__":
    main()
