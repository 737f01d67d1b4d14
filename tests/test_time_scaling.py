"""Time scaling of a move: the early-stopping dry runs decide exactly as the whole ones."""

from __future__ import annotations

import numpy as np
import pytest
from orchestrator.robots import get_robot
from orchestrator.skills import time_scaling
from orchestrator.skills.ik import IKSolver
from orchestrator.skills.targets import rot_down
from orchestrator.skills.time_scaling import feasible_time_scale
from orchestrator.skills.trajectory import CartesianLine

from orchestrator.world.world import robot_only_model


def _lines(ik: IKSolver) -> list[CartesianLine]:
    """Moves from easy (feasible as timed) to brisk (the joints need it slowed down)."""
    p0, rot = ik.tcp_pose()
    out = []
    for dx, dy, dz, yaw, speed, accel in [
        (0.1, 0.0, -0.05, 0.0, 0.2, 1.0),
        (0.0, 0.35, -0.2, 1.2, 1.0, 6.0),
        (-0.15, -0.3, -0.3, -2.0, 1.5, 10.0),
        (0.25, 0.25, -0.35, 2.5, 2.0, 12.0),
    ]:
        goal = p0 + np.array([dx, dy, dz])
        out.append(CartesianLine(p0, rot, goal, rot_down(yaw), speed, accel, 3.0, 12.0))
    return out


@pytest.mark.parametrize("robot_name", ["panda", "mobile_panda"])
def test_early_stopping_gives_the_same_factor_with_fewer_ik_steps(robot_name, monkeypatch):
    robot = get_robot(robot_name)
    ik = IKSolver(robot, robot_only_model(robot), 0.01, np.zeros(3))
    q0 = np.array(robot.home)
    ik.reset(q0)
    steps = {"n": 0}
    step = ik.reference_step

    def counting(*args):
        steps["n"] += 1
        return step(*args)

    monkeypatch.setattr(ik, "reference_step", counting)
    whole = time_scaling._excess
    factors, counts = {}, {}
    for mode in ("early", "whole"):
        if mode == "whole":  # every dry run to its end, as before the early stop
            monkeypatch.setattr(
                time_scaling,
                "_excess",
                lambda ik, line, q0, k, stop_above=None: whole(ik, line, q0, k),
            )
        steps["n"] = 0
        factors[mode] = [feasible_time_scale(ik, line, q0) for line in _lines(ik)]
        counts[mode] = steps["n"]
        np.testing.assert_array_equal(ik.q, q0)  # every dry run leaves the IK where it was
    assert factors["early"] == factors["whole"]
    assert factors["early"][0] == 1.0 and max(factors["early"]) > 1.2  # both kinds tested
    assert counts["early"] < counts["whole"], (factors, counts)


def test_a_path_slowed_where_it_exceeds_is_within_the_limits_and_faster_than_slowed_whole():
    # a pick-like motion from home: through a hover point, down to a grasp 10 cm below it
    from orchestrator.skills.blended_path import BlendedPath
    from orchestrator.skills.time_scaling import fit_path_to_joints, slow_where_exceeded

    robot = get_robot("panda")
    ik = IKSolver(robot, robot_only_model(robot), 0.01, np.zeros(3))
    q0 = np.array(robot.home)
    ik.reset(q0)
    p0, rot = ik.tcp_pose()
    grasp = np.array([0.45, -0.05, 0.225])
    durations = {}
    for mode in ("whole", "where", "where, turning"):
        turn = 0.6 if mode == "where, turning" else 0.0  # the wrist's turn limits it there

        def approach(turn: float = turn) -> BlendedPath:
            return BlendedPath(
                np.array([p0, grasp + [0.0, 0.0, 0.1], grasp]),
                rot, rot_down(turn), 1.0, 6.0, 2.0, 8.0, 0.04,
            )  # fmt: skip

        path = approach()
        fit_path_to_joints(ik, path, q0)
        if mode.startswith("where"):
            stretch = slow_where_exceeded(ik, path, q0)
            # never slower than the path slowed as a whole
            whole = path.duration * stretch
            fitted = approach()
            fit_path_to_joints(ik, fitted, q0)
            assert whole <= fitted.duration * feasible_time_scale(ik, fitted, q0) + 1e-9
            np.testing.assert_array_equal(ik.q, q0)  # the dry runs leave the IK where it was
        else:
            stretch = feasible_time_scale(ik, path, q0)
        durations[mode] = path.duration * stretch
        # the reference at that timing, every joint within the limiter's limits (with the
        # excess the limiter absorbs)
        excess = time_scaling._excess(ik, path, q0, durations[mode] / path.duration)
        assert excess <= time_scaling._FEASIBLE, mode
    # straight down to the hover's height, the path slowed where it exceeds is 10 % faster
    assert durations["where"] < 0.9 * durations["whole"], durations
