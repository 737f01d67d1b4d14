"""Whole-body differential IK of a mobile manipulator: costs that share the work.

As mink's mobile-manipulator examples do (`mobile_tidybot.py`, `mobile_kinova.py`), one QP
moves base and arm together, and the costs decide who does what:

* the arm keeps its posture (a posture task on the arm joints only): reaching far stretches it,
  so a distant target is reached by driving — the base does the long motion;
* the base's velocity is damped (a damping task on the base joints): a small correction costs
  less through the arm — the arm does the fine motion;
* each base joint is held to the base's own speed limit (0.5 m/s, 1 rad/s), not the arm's.

`IKSolver` applies this when its robot has base joints (`apply_whole_body_costs`).
"""

from __future__ import annotations

from typing import Any, Protocol

import mink
import numpy as np
from orchestrator.robots import Robot


class _Solver(Protocol):
    """What this module sets on an `IKSolver` (named structurally: ik.py imports this)."""

    robot: Robot
    frame_task: mink.FrameTask
    posture_task: Any
    tasks: list[Any]
    limits: list[Any]
    posture_follows_reset: bool


__all__ = ["ARM_POSTURE_COST", "BASE_DAMPING_COST", "apply_whole_body_costs"]

ARM_POSTURE_COST = 1e-3
"""Posture cost of each arm joint (per rad): against the frame task's 1 per m, 20 cm of
reach beyond the posture cost as much as 4 rad of posture error; with the base free (no
posture cost) it drives instead."""
BASE_DAMPING_COST = 20.0
"""Damping cost of each base joint (per m/s or rad/s of the QP step): a few millimetres of
correction go to the arm, decimetres to the base (tests/test_whole_body.py)."""


def apply_whole_body_costs(ik: _Solver, model, velocity_limit: float) -> None:
    """Give `ik` the whole-body tasks and the base's velocity limits (in place).

    Args:
        ik: A solver whose robot has base joints (`robot.base_joints`, first in `arm_joints`).
        model: The robot-only MjModel the solver works on.
        velocity_limit: The solver's cap on the arm joints' speed [rad/s].
    """
    robot = ik.robot
    nb = len(robot.base_joints)
    posture = np.zeros(model.nv)
    posture[nb : robot.n_arm] = ARM_POSTURE_COST
    ik.posture_task = mink.PostureTask(model, cost=posture)
    damping = np.zeros(model.nv)
    damping[:nb] = BASE_DAMPING_COST
    ik.tasks = [ik.frame_task, ik.posture_task, mink.DampingTask(model, damping)]
    ik.posture_follows_reset = True  # the arm's posture is where each motion starts
    limits = robot.joint_velocity_limits()
    caps = np.concatenate([limits[:nb], np.minimum(limits[nb:], velocity_limit)])
    speeds = {j: float(v) for j, v in zip(robot.arm_joints, caps, strict=True)}
    ik.limits = [
        mink.ConfigurationLimit(model),
        mink.VelocityLimit(model, speeds),
    ]
