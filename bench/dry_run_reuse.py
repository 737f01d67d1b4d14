"""Can a move's start solve the IK fewer times without changing the arm's path? Two measured
answers for issue 43 (its point 3), on the bundled flows.

A move's start (skills/move.py) runs the IK along its path several times before the arm
moves: `fit_path_to_joints` (two passes, blended paths), `feasible_time_scale` (one run, then
a bisection of up to four), then the full-rate `dry_run` whose rows the ticks replay (those
solves are the move's own, moved forward). The first three decide the path's timing; the arm's
trajectory stays the same, bit for bit, only if every decision comes out the same.

1. Solves per source: `IKSolver.reference_step` counted by its caller.
2. Coarser sampling as a pre-filter of the bisection: each bisection run's excess (the
   reference's speed or acceleration over the limits, `time_scaling._excess`) at the dry runs'
   stride (3 ticks) and at a coarser one. A coarse run could decide "infeasible" or
   "feasible" in place of the fine one only where the two are known to lie on the same side of
   the bound (1.08) given the largest coarse/fine gap; the figures say how often that is.
3. Reuse between `fit_path_to_joints`'s passes (and its last pass and the first
   `_excess`): exact only when a pass's `limit_speed` leaves the path's timing unchanged, bit
   for bit; counted.

    python bench/dry_run_reuse.py [--scenarios sorting pick_place] [--seeds 2]
"""

from __future__ import annotations

import argparse
import collections
import sys

import numpy as np
from orchestrator.skills import blended_path, time_scaling
from orchestrator.skills import ik as ik_module

from orchestrator.engine.runner import run_episode
from orchestrator.language.load import load_scenario

COARSE = (6, 9)
"""Coarser strides tried (control ticks per dry-run step)."""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenarios", nargs="+", default=["sorting", "pick_place"])
    parser.add_argument("--seeds", type=int, default=2)
    args = parser.parse_args()
    counts: collections.Counter[str] = collections.Counter()
    pairs: list[tuple[int, float, float]] = []  # (coarse stride, fine excess, coarse excess)
    no_ops: list[bool] = []

    solve = ik_module.IKSolver.reference_step

    def counted(self, pos, rot, dt):  # type: ignore[no-untyped-def]
        counts[sys._getframe(1).f_code.co_name] += 1
        return solve(self, pos, rot, dt)

    excess = time_scaling._excess

    def studied(ik, line, q0, k, stop_above=None):  # type: ignore[no-untyped-def]
        out = excess(ik, line, q0, k, stop_above)
        if stop_above is not None:  # a bisection run: the same k, whole, fine and coarse
            ik_module.IKSolver.reference_step = solve  # (the study's own solves uncounted)
            fine = excess(ik, line, q0, k)
            stride = time_scaling.STRIDE
            for coarse in COARSE:
                time_scaling.STRIDE = coarse
                pairs.append((coarse, fine, excess(ik, line, q0, k)))
            time_scaling.STRIDE = stride
            ik_module.IKSolver.reference_step = counted
        return out

    limit_speed = blended_path.BlendedPath.limit_speed

    def watched(self, s, v, a):  # type: ignore[no-untyped-def]
        t0, v0 = self._t.copy(), self._v.copy()
        limit_speed(self, s, v, a)
        no_ops.append(bool(np.array_equal(t0, self._t) and np.array_equal(v0, self._v)))

    ik_module.IKSolver.reference_step = counted
    time_scaling._excess = studied
    blended_path.BlendedPath.limit_speed = watched
    for name in args.scenarios:
        loaded = load_scenario(name)
        for seed in range(args.seeds):
            run_episode(loaded, seed)
    total = sum(counts.values())
    print(f"IK solves in {args.scenarios} x {args.seeds} seeds: {total}")
    for caller, n in counts.most_common():
        print(f"  {caller:22s} {n:6d}  {n / total:6.1%}")
    bound = time_scaling._FEASIBLE
    for coarse in COARSE:
        rows = np.array([(f, c) for s, f, c in pairs if s == coarse])
        if not len(rows):
            continue
        ratio = rows[:, 1] / rows[:, 0]
        lo, hi = float(ratio.min()), float(ratio.max())
        fine, c = rows[:, 0], rows[:, 1]
        # decided by the coarse run alone, given the gap seen: surely above, or surely below
        above = c / hi > bound
        below = c / lo <= bound
        print(
            f"bisection runs, stride {coarse} vs 3: {len(rows)}, coarse/fine excess "
            f"{lo:.3f}-{hi:.3f}; decidable from the coarse run alone: "
            f"{int(np.sum(above | below))} ({np.mean(above | below):.0%}); fine excess within "
            f"10 % of the bound {bound}: {np.mean(np.abs(fine / bound - 1.0) < 0.1):.0%}"
        )
    print(
        f"fit_path_to_joints passes leaving the timing unchanged (exact reuse possible): "
        f"{sum(no_ops)}/{len(no_ops)}"
    )


if __name__ == "__main__":
    main()
