"""What the safety guards cost: pick_place with every guard vs. without the newer ones.

Each pair runs the same seed twice in this process — once as bundled (workspace,
contact_force, collision, sensor_health, joint_velocity, joint_torque; joint_limits and
grasp_lost from the machine) and once with only workspace and contact_force at the scenario
level — in alternating order (ABBA), so drift of a shared machine cancels. The figure is the
median of the per-pair wall-time ratios, with its interquartile range; per-check costs are
timed on a recorded trajectory (mean of many calls).

    python bench/guard_overhead.py [--pairs 20] [--scenario pick_place]
"""

from __future__ import annotations

import argparse
import statistics
import time

from orchestrator.engine.runner import run_episode
from orchestrator.language.load import load_scenario

BASE_GUARDS = (
    "guards={workspace: {min: [0.05, -0.6, 0.15], max: [0.95, 0.6, 1.2]}, "
    "contact_force: {max_n: 60}}"
)
"""The scenario guards of pick_place before the collision, sensor_health, joint_velocity and
joint_torque guards existed."""


def _wall(loaded, seed: int) -> float:
    t0 = time.perf_counter()
    result = run_episode(loaded, seed)
    wall = time.perf_counter() - t0
    if result.outcome != "succeeded":
        raise SystemExit(f"seed {seed} did not succeed ({result.outcome}): not a fair pair")
    return wall


def _per_check(loaded, seed: int, calls: int = 2000) -> dict[str, float]:
    """Mean cost of each guard's `check` [us] at the end of an episode's trajectory."""
    from orchestrator.engine.context import Context  # noqa: F401 - type only

    costs: dict[str, float] = {}

    class Probe:
        def on_start(self, ctx, executor) -> None:
            self.ctx, self.ex = ctx, executor

        def on_tick(self, ctx, executor) -> None:
            if ctx.tick == 150:  # mid-episode: moving, with contacts
                for guard in executor.active_guards:
                    t0 = time.perf_counter()
                    for _ in range(calls):
                        guard.check(ctx)
                    costs[guard.name] = (time.perf_counter() - t0) / calls * 1e6

        def on_end(self, *args) -> None:
            pass

    run_episode(loaded, seed, [Probe()])
    return costs


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--pairs", type=int, default=20, help="Paired runs (seeds).")
    parser.add_argument("--scenario", default="pick_place")
    args = parser.parse_args()
    full = load_scenario(args.scenario)
    base = load_scenario(args.scenario, [BASE_GUARDS])
    _wall(full, 10_000)  # warm the caches once, as a batch worker would
    _wall(base, 10_000)
    ratios = []
    for i in range(args.pairs):
        if i % 2 == 0:
            a = _wall(full, i)
            b = _wall(base, i)
        else:
            b = _wall(base, i)
            a = _wall(full, i)
        ratios.append(a / b)
    q1, med, q3 = statistics.quantiles(ratios, n=4)
    spread = f"IQR {q1:.3f}-{q3:.3f}, {args.pairs} pairs"
    print(f"{args.scenario}: all guards / base guards wall time = {med:.3f} ({spread})")
    for name, us in sorted(_per_check(full, 0).items(), key=lambda kv: -kv[1]):
        print(f"  {name:15s} {us:6.2f} us per check")


if __name__ == "__main__":
    main()
