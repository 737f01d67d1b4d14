"""What following the dry run saves: a move's path ticks replayed vs solved live, in pairs.

A move's ticks on its path follow the reference its dry run computed (`IKSolver.follow`)
instead of solving the IK again (docs/ik.md). This runs each episode twice in one process,
once as it runs and once with the replay switched off (every tick solves live, as before
issue 28), alternating which goes first, and reports per scenario the CPU time per physics
step of both, the median of the per-pair ratios, and the IK solves per episode. Pairs in one
process, interleaved, share the machine's load: compare the ratio, not the absolute figures.

    python bench/ik_replay.py [--scenario sorting pick_place] [--seeds 3]
"""

from __future__ import annotations

import argparse
import statistics
import time


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", nargs="+", default=["sorting", "pick_place"])
    parser.add_argument("--seeds", type=int, default=3)
    args = parser.parse_args()

    from orchestrator.skills import ik, move

    from orchestrator.engine.runner import run_episode
    from orchestrator.language.load import load_scenario

    solves = [0]
    solve, follow = ik.IKSolver.reference_step, move.Move._follow

    def counted(self, *a):
        solves[0] += 1
        return solve(self, *a)

    ik.IKSolver.reference_step = counted  # type: ignore[method-assign]
    for name in args.scenario:
        loaded = load_scenario(name)
        dt = loaded.scenario.physics.timestep_s
        run_episode(loaded, 10_000)  # warm the caches, as a batch worker would
        us: dict[bool, list[float]] = {True: [], False: []}
        count: dict[bool, list[int]] = {True: [], False: []}
        ratios = []
        for seed in range(args.seeds):
            order = (True, False) if seed % 2 == 0 else (False, True)
            pair = {}
            for replay in order:
                move.Move._follow = follow if replay else (lambda *a: None)  # type: ignore[method-assign]
                solves[0] = 0
                cpu0 = time.process_time()
                r = run_episode(loaded, seed)
                cpu = time.process_time() - cpu0
                pair[replay] = cpu / (r.sim_time / dt) * 1e6
                us[replay].append(pair[replay])
                count[replay].append(solves[0])
            ratios.append(pair[True] / pair[False])
        move.Move._follow = follow  # type: ignore[method-assign]
        print(
            f"{name} ({args.seeds} seeds): CPU per physics step {statistics.median(us[True]):.0f} "
            f"us replayed vs {statistics.median(us[False]):.0f} us live (median pair ratio "
            f"{statistics.median(ratios):.3f}, range {min(ratios):.3f}-{max(ratios):.3f}); "
            f"IK solves per episode {statistics.median(count[True]):.0f} vs "
            f"{statistics.median(count[False]):.0f}"
        )


if __name__ == "__main__":
    main()
