"""CPU time of one differential-IK step (`IKSolver.reference_step`), the way it was and now.

Runs the IK along a fixed Cartesian motion (a 40 cm line there and back with a 60 deg turn of
the hand, at the 100 Hz control rate) for the Panda and the mobile Panda, in three variants:

* `mink`: `mink.solve_ik` assembling the QP from scratch, the posture's projector by SVD
  pseudo-inverse (what the solver did before skills/ik_qp.py);
* `in place`: `IKProblem` (the same arithmetic, no per-call allocations), SVD projector;
* `now`: `IKProblem` with the 6x6-inverse projector (what the solver does).

Reports the median over `--repeats` runs of the CPU time per step [us] and the ratio to `mink`.

With `--scenario`, runs whole episodes instead, alternating seed by seed between the IK as it
was (`mink.solve_ik`, SVD projector) and as it is, and reports each one's median CPU real-time
factor (simulated / CPU time): an A/B in one process, under the same load.

    python bench/ik_step.py [--steps 400] [--repeats 5]
    python bench/ik_step.py --scenario sorting --seeds 5
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np


def _run(robot_name: str, variant: str, steps: int) -> float:
    """CPU time per `reference_step` [us] of one run of the motion."""
    import mink
    from orchestrator.robots import get_robot
    from orchestrator.skills.ik import IKSolver
    from orchestrator.skills.posture import NullspacePostureTask
    from orchestrator.skills.targets import rot_down

    from orchestrator.world.world import robot_only_model

    robot = get_robot(robot_name)
    ik = IKSolver(robot, robot_only_model(robot), 0.01, np.zeros(3))
    ik.reset(np.array(robot.home))
    if variant != "now" and isinstance(ik.posture_task, NullspacePostureTask):
        ik.posture_task.projector_from = ik.posture_task.pinv_projector  # type: ignore[method-assign]
    if variant == "mink":
        ik._solve = lambda dt: mink.solve_ik(  # type: ignore[method-assign]
            ik.config, ik.tasks, dt, "daqp", damping=ik.damping, limits=ik.limits
        )
    p0, _ = ik.tcp_pose()
    targets = []
    for i in range(steps):
        s = 0.5 - 0.5 * np.cos(2 * np.pi * i / steps)  # 0 -> 1 -> 0
        targets.append((p0 + np.array([0.0, 0.4 * s, -0.1 * s]), rot_down(np.pi / 3 * s)))
    cpu0 = time.process_time()
    for pos, rot in targets:
        ik.reference_step(pos, rot, 0.01)
    return (time.process_time() - cpu0) / steps * 1e6


def _old_ik(on: bool) -> None:
    """Switch every IKSolver to the IK as it was (mink.solve_ik, SVD projector) or back."""
    import mink
    from orchestrator.skills.ik import IKSolver
    from orchestrator.skills.posture import NullspacePostureTask

    if on:
        IKSolver._solve = lambda self, dt: mink.solve_ik(  # type: ignore[method-assign]
            self.config, self.tasks, dt, "daqp", damping=self.damping, limits=self.limits
        )
        NullspacePostureTask.projector_from = NullspacePostureTask.pinv_projector  # type: ignore[method-assign]
    else:
        IKSolver._solve = _NEW[0]  # type: ignore[method-assign]
        NullspacePostureTask.projector_from = _NEW[1]  # type: ignore[method-assign]


_NEW: list = []


def episodes(scenario: str, seeds: int) -> None:
    """Median CPU real-time factor of `scenario` over `seeds` seeds, old IK and new, A/B."""
    from orchestrator.skills.ik import IKSolver
    from orchestrator.skills.posture import NullspacePostureTask

    from orchestrator.engine.runner import run_episode
    from orchestrator.language.load import load_scenario

    _NEW[:] = [IKSolver._solve, NullspacePostureTask.projector_from]
    loaded = load_scenario(scenario)
    run_episode(loaded, 10_000)  # warm the caches once, as a batch worker would
    rtf: dict[str, list[float]] = {"old": [], "new": []}
    for seed in range(seeds):
        for variant in ("old", "new") if seed % 2 == 0 else ("new", "old"):
            _old_ik(variant == "old")
            cpu0 = time.process_time()
            result = run_episode(loaded, seed)
            rtf[variant].append(result.sim_time / (time.process_time() - cpu0))
    _old_ik(False)
    old, new = statistics.median(rtf["old"]), statistics.median(rtf["new"])
    print(
        f"{scenario}: median CPU RTF {old:.2f}x with the old IK, {new:.2f}x now "
        f"({new / old:.2f}x) over {seeds} seeds"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=400, help="IK steps per run")
    parser.add_argument("--repeats", type=int, default=5, help="runs per variant")
    parser.add_argument("--scenario", help="run episodes of this scenario instead (A/B)")
    parser.add_argument("--seeds", type=int, default=5, help="seeds per variant (--scenario)")
    args = parser.parse_args()
    if args.scenario:
        episodes(args.scenario, args.seeds)
        return
    for robot_name in ("panda", "mobile_panda"):
        times = {}
        for variant in ("mink", "in place", "now"):
            _run(robot_name, variant, 50)  # warm up
            times[variant] = statistics.median(
                _run(robot_name, variant, args.steps) for _ in range(args.repeats)
            )
        base = times["mink"]
        print(
            f"{robot_name:13s} "
            + ", ".join(f"{k} {v:6.1f} us" for k, v in times.items())
            + f"; now / mink = {times['now'] / base:.2f}"
        )


if __name__ == "__main__":
    main()
