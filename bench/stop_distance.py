"""How far and how long the arm travels after an e-stop, against its speed and the stop's
deceleration.

An `estop` is injected at several points of a pick_place cycle (while it carries the cube at
full speed, while it descends, while it lifts); for each deceleration limit
(`physics.safe_stop.max_decel_rad_s2`) the table gives the arm's fastest joint and the TCP's
speed at the moment of the stop, and the reported `stop_time_s` (violation -> every joint
below `rest_speed_rad_s`, 0.01 rad/s, and the brakes on), `stop_distance_mm` (TCP travel after
the violation), `stop_distance_min_mm` (the braking profile's own travel from the speed at the
trip) and their ratio.

    python bench/stop_distance.py [--seed 0] [--decel 25 50 100]
"""

from __future__ import annotations

import argparse

import numpy as np

from orchestrator.engine.runner import run_episode
from orchestrator.language.load import load_scenario

WHEN = (
    "PICK.GRASP.APPROACH+0.3",
    "PICK.GRASP.APPROACH+0.7",
    "PICK.GRASP.LIFT+0.1",
    "TRANSPORT+0.1",
    "TRANSPORT+0.3",
    "TRANSPORT+0.5",
    "TRANSPORT+0.7",
    "RETREAT+0.1",
)


class _AtAbort:
    """Keeps the arm's fastest joint speed of the last tick before the stop began."""

    def __init__(self) -> None:
        self.qd_max = 0.0
        self.frozen = False

    def on_start(self, ctx, executor) -> None:
        pass

    def on_tick(self, ctx, executor) -> None:
        if not self.frozen:
            if executor.violation_t is not None:
                self.frozen = True
            else:
                self.qd_max = float(np.max(np.abs(ctx.qd)))

    def on_end(self, ctx, executor, result) -> None:
        pass


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--decel", type=float, nargs="+", default=[25.0, 50.0, 100.0])
    args = ap.parse_args()
    print(
        "| e-stop at | max decel [rad/s²] | fastest joint [rad/s] | TCP speed [m/s] "
        "| stop time [s] | stop distance [mm] | profile's own [mm] | ratio | outcome |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    for when in WHEN:
        for decel in args.decel:
            loaded = load_scenario(
                "pick_place",
                [f"physics.safe_stop.max_decel_rad_s2={decel}"],
                [f"estop@{when}"],
            )
            probe = _AtAbort()
            result = run_episode(loaded, args.seed, [probe])
            m = result.metrics
            low = m.get("stop_distance_min_mm") or 0.0
            ratio = f"{m['stop_distance_mm'] / low:.2f}" if low > 0 else "-"
            print(
                f"| {when} | {decel:g} | {probe.qd_max:.2f} | {m.get('stop_speed_m_s')} "
                f"| {m.get('stop_time_s')} | {m.get('stop_distance_mm')} | {low} | {ratio} "
                f"| {result.outcome} |"
            )


if __name__ == "__main__":
    main()
