"""Headless real-time factor of a scenario: simulated time / wall time, per episode.

Reports the median over seeds for (a) episodes run in one process (the batch case: robot
model, meshes and IK model cached after the first episode) and (b) `orchestrator run` as a
fresh process per episode (wall_time from its JSON: world build + simulation, cold caches).

    python bench/realtime.py [--scenario pick_place] [--seeds 20] [--cli 5]
    python bench/realtime.py --scenario mobile_search --seeds 10 --cli 0

Also reported: the CPU time of the process over the episodes (`time.process_time`), which on
a machine shared with other work is the honest one-core figure (wall time includes waiting).
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
    parser.add_argument("--scenario", default="pick_place", help="bundled name or path")
    args = parser.parse_args()

    from orchestrator.engine.runner import run_episode
    from orchestrator.language.load import load_scenario

    loaded = load_scenario(args.scenario)
    run_episode(loaded, 10_000)  # warm the caches once, as a batch worker would
    rtf, cpu_rtf, cycle = [], [], []
    for seed in range(args.seeds):
        cpu0 = time.process_time()
        r = run_episode(loaded, seed)
        cpu = time.process_time() - cpu0
        rtf.append(r.sim_time / r.wall_time)
        cpu_rtf.append(r.sim_time / cpu)
        cycle.append(r.metrics["cycle_time"] or r.sim_time)
    print(
        f"{args.scenario} in-process: median RTF {statistics.median(rtf):5.1f}x wall "
        f"(min {min(rtf):.1f}x, max {max(rtf):.1f}x), {statistics.median(cpu_rtf):5.1f}x CPU "
        f"(min {min(cpu_rtf):.1f}x) over {args.seeds} seeds; "
        f"median cycle_time {statistics.median(cycle):.2f} s (max {max(cycle):.2f} s)"
    )
    cli = []
    for seed in range(args.cli):
        out = subprocess.run(
            [
                sys.executable,
                "-m",
                "orchestrator.cli",
                "run",
                args.scenario,
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
            f"(min {min(cli):.1f}x, max {max(cli):.1f}x) over {args.cli} runs (cold caches)"
        )


if __name__ == "__main__":
    main()
