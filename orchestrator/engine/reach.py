"""Can the arm get its TCP to a point? An IK solve on a copy of the robot's model.

Used before anything moves (a live session's guardrail, `run --set`): the solve starts from
the arm's current configuration, gripper pointing down, on its own `IKSolver` (never the
running one), and stops once the TCP is within tolerance or makes no more progress.
"""

from __future__ import annotations

import numpy as np

from ..skills.ik import IKSolver
from ..skills.targets import rot_down
from ..world.world import World, robot_only_model

__all__ = ["ik_miss"]

_IK_DT = 0.02
_IK_ITERATIONS = 250
_STALL_ITERATIONS = 20


def ik_miss(world: World, q_arm: np.ndarray, pos: np.ndarray, tol_m: float) -> float:
    """The closest the IK gets the TCP to `pos` [m] from `q_arm` [rad], gripper down.

    Args:
        world: The world (its robot and base position; nothing in it is changed).
        q_arm: Arm joint angles to start from [rad]. Shape (n_arm,).
        pos: The point, world frame [m]. Shape (3,).
        tol_m: Stop as soon as the TCP is this close [m].

    Returns:
        The remaining distance [m] (≤ `tol_m` if reachable).
    """
    robot = world.robot
    ik = IKSolver(robot, robot_only_model(robot), _IK_DT, world.scenario.robot.base_pos)
    ik.reset(np.asarray(q_arm, float))
    rot = rot_down(0.0)
    history: list[float] = []
    miss = float("inf")
    for _ in range(_IK_ITERATIONS):
        ik.step(pos, rot)
        miss = float(np.linalg.norm(ik.error[:3]))
        if miss <= tol_m:
            break
        history.append(miss)
        if len(history) > _STALL_ITERATIONS and history[-_STALL_ITERATIONS - 1] - miss < 1e-5:
            break  # no progress: stuck at a joint limit or the edge of the reach
    return miss
