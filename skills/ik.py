"""The bridge: Cartesian intents -> joint setpoints with mink differential IK."""

from __future__ import annotations

import mink
import numpy as np
from orchestrator.robots import Robot

__all__ = ["IKSolver"]


class IKSolver:
    """Differential IK of the TCP on the robot's own kinematic model (mink + daqp).

    The solver integrates its own joint state: seed it from the measured joints with
    `reset`, then call `step` once per control tick with the pose the TCP should have.

    Args:
        robot: The robot.
        model: The robot-only MjModel (no scene objects).
        dt: Control period in [s].
        base_pos: Position of the robot base in the world [m]; targets are given in the world.
        velocity_limit: Joint speed limit used by the IK in [rad/s].
        posture_cost: Weight of the posture task that keeps the arm near its seed.
        damping: Levenberg-Marquardt damping of the QP.
    """

    def __init__(
        self,
        robot: Robot,
        model,
        dt: float,
        base_pos: np.ndarray,
        velocity_limit: float = 2.0,
        posture_cost: float = 1e-3,
        damping: float = 1e-4,
    ) -> None:
        self.robot = robot
        self.dt = dt
        self.base_pos = np.asarray(base_pos, float).copy()
        self.n = robot.n_arm
        self.config = mink.Configuration(model)
        self.frame_task = mink.FrameTask(
            robot.tcp_site, "site", position_cost=1.0, orientation_cost=1.0, lm_damping=1e-6
        )
        self.posture_task = mink.PostureTask(model, cost=posture_cost)
        self.limits = [
            mink.ConfigurationLimit(model),
            mink.VelocityLimit(model, {j: velocity_limit for j in robot.arm_joints}),
        ]
        self.damping = damping
        self.velocity = np.zeros(self.n)
        self.acceleration = np.zeros(self.n)
        self._error: np.ndarray | None = np.zeros(6)

    @property
    def q(self) -> np.ndarray:
        """The IK's joint angles (arm) [rad]. Shape (n,)."""
        return self.config.q[: self.n]

    def reset(self, q_arm: np.ndarray) -> None:
        """Seed the solver with measured arm angles; the posture task holds this posture."""
        q = self.config.q.copy()
        q[: self.n] = q_arm
        self.config.update(q)
        self.posture_task.set_target(q)
        self.velocity[:] = 0.0
        self.acceleration[:] = 0.0
        self._error = None

    def tcp_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """World TCP position [m] and rotation at the IK's joint angles."""
        T = self.config.get_transform_frame_to_world(self.robot.tcp_site, "site")
        return T.translation() + self.base_pos, T.rotation().as_matrix()

    @property
    def error(self) -> np.ndarray:
        """Frame-task error after the last `step` (position [m], then rotation [rad]). Shape (6,).

        Computed when read: most ticks never look at it."""
        if self._error is None:
            self._error = self.frame_task.compute_error(self.config)
        return self._error

    def step(self, pos: np.ndarray, rot: np.ndarray | mink.SO3) -> np.ndarray:
        """One control tick towards the world pose (`pos` [m], `rot` a 3x3 matrix or an SO3).

        Returns:
            The new joint angles [rad]; `velocity` and `acceleration` hold the joint speeds
            that led there and their change over the tick.
        """
        so3 = rot if isinstance(rot, mink.SO3) else mink.SO3.from_matrix(rot)
        target = mink.SE3.from_rotation_and_translation(so3, np.asarray(pos) - self.base_pos)
        self.frame_task.set_target(target)
        v = mink.solve_ik(
            self.config,
            [self.frame_task, self.posture_task],
            self.dt,
            "daqp",
            damping=self.damping,
            limits=self.limits,
        )
        self.config.integrate_inplace(v, self.dt)
        self.acceleration[:] = (v[: self.n] - self.velocity) / self.dt
        self.velocity[:] = v[: self.n]
        self._error = None
        return self.q
