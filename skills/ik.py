"""The bridge: Cartesian intents -> joint setpoints with mink differential IK.

The IK integrates its own joint reference (open loop, from the skill's Cartesian trajectory).
What reaches the controller is that reference passed through a limiter (`JointLimiter`): the
commanded joint velocity, acceleration and jerk never exceed the robot's datasheet limits,
however abruptly the IK's wish changes (near a singularity it can flip a joint's velocity in
one tick). A feasible reference passes through unchanged.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from orchestrator.robots import Robot

from .joint_limiter import JointLimiter
from .plain_state import plain_state, restore_plain

if TYPE_CHECKING:
    import mink

    from .ik_qp import IKProblem

__all__ = [
    "ACCELERATION_MARGIN",
    "COMMAND_MARGIN",
    "POSTURE_COST",
    "POSTURE_TIME_CONSTANT_S",
    "IKSolver",
]

COMMAND_MARGIN = 0.85
"""Fraction of the robot's joint velocity and jerk limits the commands may use: the rest is
for tracking (the arm follows a command with a small overshoot), so the measured motion stays
within them."""

ACCELERATION_MARGIN = 0.7
"""Fraction of the robot's joint acceleration limits the commands may use. The arm's measured
acceleration, every physics step, is the command's plus what the command does not know: the
encoders' quantized velocity through the joint damping (+0.15 of joint 3's limit above a
command at 0.85, sorting seed 2), a held parcel grazing its neighbour as it is lifted (+0.26
of joint 2's for one step, sorting seed 3). At 0.85 those reached 0.996x and 1.01x the
datasheet; at 0.7 the worst is 0.90x (docs/physical-honesty.md)."""

POSTURE_COST = 1.0
"""Weight of the nullspace posture task [1/rad], as the frame task's (1 per m and per rad): in
the nullspace it competes with nothing but the QP's damping (1e-2), so it holds the redundancy
(three rounds of a 20 cm square: 0.40 rad of drift without it, < 1e-4 rad with it,
tests/test_physical_honesty.py)."""
POSTURE_TIME_CONSTANT_S = 0.2
"""Time constant of the posture's return [s] (the task's gain is dt / this per IK step)."""
POSTURE_RAMP_S = 0.3
"""After `reset` the posture's gain rises from 0 over this long [s] (smoothstep): a move that
starts away from the posture (the previous one ended before its redundancy had settled) starts
its joint motion smoothly rather than with a step of the joints' velocity demand."""


class IKSolver:
    """Differential IK of the TCP on the robot's own kinematic model (mink + daqp).

    The solver integrates its own joint state: seed it from the measured joints with
    `reset`, then call `step` once per control tick with the pose the TCP should have.

    Args:
        robot: The robot.
        model: The robot-only MjModel (no scene objects).
        dt: Control period in [s].
        base_pos: Position of the robot base in the world [m]; targets are given in the world.
        velocity_limit: Joint speed limit used by the IK in [rad/s] (capped by the robot's).
        posture_cost: Weight of the posture task (`NullspacePostureTask`) [1/rad]: the
            arm's redundancy held at `posture` without costing the TCP task accuracy.
        damping: Levenberg-Marquardt damping of the QP.
        posture: The arm's preferred joint angles [rad], shape (n,): the robot's home if
            None (as the Cartesian impedance's nullspace posture). `set_posture` changes it.
    """

    def __init__(
        self,
        robot: Robot,
        model,
        dt: float,
        base_pos: np.ndarray,
        velocity_limit: float = 2.0,
        posture_cost: float = POSTURE_COST,
        damping: float = 1e-2,
        posture: np.ndarray | None = None,
    ) -> None:
        import mink

        from .posture import NullspacePostureTask
        from .whole_body import apply_whole_body_costs

        # the classes `reference_step` tests for on every call, looked up once (a relative
        # import in the step cost more than the test; mink is imported here, not at this
        # module's import: start-up, docs/performance.md)
        self._so3 = mink.SO3
        self._nullspace = NullspacePostureTask

        self.robot = robot
        """The robot it solves for (`orchestrator.robots`)."""
        self.dt = dt
        """Control period [s]: one `step` advances the IK by this much."""
        self.base_pos = np.asarray(base_pos, float).copy()
        """Position of the robot base in the world [m] (targets are given in the world)."""
        self.n = robot.n_arm
        """Number of arm joints: the length of `q` and of every joint vector here."""
        self.config = mink.Configuration(model)
        """mink's configuration of the robot-only model (the IK's joint state)."""
        self.frame_task = mink.FrameTask(
            robot.tcp_site, "site", position_cost=1.0, orientation_cost=1.0, lm_damping=1e-6
        )
        """The TCP pose task (mink `FrameTask`, position and orientation cost 1)."""
        self.posture_task: mink.Task = NullspacePostureTask(model, self.frame_task, posture_cost)
        """Holds the arm's redundancy at the posture (`set_posture`) in the TCP task's
        nullspace."""
        self.tasks: list[mink.Task] = [self.frame_task, self.posture_task]
        """The tasks of the QP, in order (a whole-body robot adds its base's)."""
        self.posture_follows_reset = False
        """Re-anchor the posture at the joints of every `reset` (the whole-body solver's
        arm posture, skills/whole_body.py) instead of holding `set_posture`'s."""
        self.limits = [
            mink.ConfigurationLimit(model),
            mink.VelocityLimit(model, {j: velocity_limit for j in robot.arm_joints}),
        ]
        """The QP's constraints: the joint ranges and the IK's joint speed limit."""
        self.damping = damping
        """Levenberg-Marquardt damping of the QP."""
        self._model = model
        self._target = mink.SE3.identity().copy()
        """The frame task's target, rewritten in place by `reference_step`."""
        self._problem: IKProblem | None = None
        self._problem_key: tuple | None = None
        self.velocity = np.zeros(self.n)
        """Joint velocity of the limited command now [rad/s], shape (n,)."""
        self.acceleration = np.zeros(self.n)
        """Joint acceleration of the limited command now [rad/s^2], shape (n,)."""
        self.reference_velocity = np.zeros(self.n)
        """The IK's own joint velocity on the last `step` (before the limiter) [rad/s]."""
        self._error: np.ndarray | None = np.zeros(6)
        self._since_reset = 0.0
        self._restart: tuple[np.ndarray, np.ndarray | None] | None = None
        """A restart `restart_from` asked for, done again at the next `step`."""
        margin = COMMAND_MARGIN
        self.limiter = JointLimiter(
            dt,
            np.minimum(margin * robot.joint_velocity_limits(), velocity_limit),
            ACCELERATION_MARGIN * np.asarray(robot.acceleration_limits, float),
            margin * np.asarray(robot.jerk_limits, float),
        )
        """Bounds the command's joint speed, acceleration and jerk within the datasheet's
        (with margins): what `command` follows (skills/joint_limiter.py)."""
        if robot.mobile:  # base + arm in one QP (skills/whole_body.py)
            apply_whole_body_costs(self, model, velocity_limit)
        self.set_posture(robot.home if posture is None else posture)

    @property
    def q(self) -> np.ndarray:
        """The IK's joint angles (arm) [rad]. Shape (n,)."""
        return self.config.q[: self.n]

    def snapshot_state(self) -> dict[str, Any]:
        """What the solver holds between two ticks, as plain data (a run snapshot): its own
        plain attributes, its joint angles, the frame task's target, the posture task's and
        the limiter's state. The assembled QP (`_problem`) is a cache made again on the next
        solve from the same tasks and limits."""
        state: dict[str, Any] = {
            k: v for k, v in plain_state(self).items() if not k.startswith("_problem")
        }
        target = self.frame_task.transform_target_to_world
        state["$q"] = self.config.q.copy()
        state["$frame_target"] = None if target is None else target.wxyz_xyz.copy()
        state["$own_target"] = self._target.wxyz_xyz.copy()
        state["$posture"] = plain_state(self.posture_task)
        state["$limiter"] = plain_state(self.limiter)
        return state

    def restore_state(self, data: dict[str, Any]) -> None:
        """Take back what `snapshot_state` recorded."""
        data = dict(data)
        q, frame_target = data.pop("$q"), data.pop("$frame_target")
        own_target = data.pop("$own_target")
        restore_plain(self.posture_task, data.pop("$posture"))
        restore_plain(self.limiter, data.pop("$limiter"))
        restore_plain(self, data)
        self.config.update(np.array(q, dtype=float))
        if frame_target is not None:
            self.frame_task.set_target(self._so3_se3(frame_target))
        np.copyto(self._target.wxyz_xyz, own_target)
        self._problem, self._problem_key = None, None

    @staticmethod
    def _so3_se3(wxyz_xyz: np.ndarray) -> Any:
        import mink

        return mink.SE3(wxyz_xyz=np.array(wxyz_xyz, dtype=float))

    def reset(
        self,
        q_arm: np.ndarray,
        qd_arm: np.ndarray | None = None,
        qdd_arm: np.ndarray | None = None,
    ) -> None:
        """Seed the solver with the arm's state (angles [rad], and the velocity [rad/s] and
        acceleration [rad/s^2] it is moving with, zero by default). The posture it holds
        stays (`set_posture`): re-anchored at every move's start, the redundancy would drift
        from move to move."""
        q = self.config.q.copy()
        q[: self.n] = q_arm
        self.config.update(q)
        self.velocity[:] = 0.0 if qd_arm is None else qd_arm
        self.acceleration[:] = 0.0 if qdd_arm is None else qdd_arm
        self.limiter.reset(q_arm, self.velocity, self.acceleration)
        self._restart = None
        self._error = None
        self._since_reset = 0.0
        if self.posture_follows_reset:
            self.posture_task.set_target(q)

    def set_posture(self, q_arm: np.ndarray) -> None:
        """Hold the arm's redundancy at the joint angles `q_arm` [rad] (shape (n,))."""
        q = self.config.q.copy()
        q[: self.n] = q_arm
        self.posture_task.set_target(q)

    def restart_from(self, q_arm: np.ndarray, qd_arm: np.ndarray | None = None) -> None:
        """Restart the limited command from the controller's setpoint: angles `q_arm` [rad]
        moving at `qd_arm` [rad/s] (at rest by default).

        The IK's own reference keeps its place: the command catches up with it within the
        robot's limits. A move starts its command here from where the controller's setpoint
        is (not from the measured joints, which sag away from it under a load the
        controller's model lacks): the setpoint, and with it the torque, stay continuous
        where one motion hands over to the next. A pause restarts it here at rest, so a
        resumed motion continues on the path it was on.

        Given views of the controller's setpoint (`Controller.q_d`, `qd_d`), the next `step`
        restarts again from where they are then: between a move's `start` and its first
        `step` the controller runs a control tick on what the previous skill left it (a
        setpoint coming to rest), and a command restarted from the setpoint as it was at
        `start` stepped its velocity back by that tick's change (up to 1.2x joint 3's
        acceleration limit for a step, pick_place_vision LOWER)."""
        self.limiter.reset(q_arm, qd_arm)
        self.velocity[:] = self.limiter.velocity
        self.acceleration[:] = 0.0
        self._restart = (q_arm, qd_arm)

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
            The joint angles [rad] the command starts the tick from; `velocity` holds its
            joint velocity there and `acceleration` the constant joint acceleration over the
            tick (within the robot's limits, jerk-limited): what the controller integrates
            until the next tick, where it arrives at `command`.
        """
        q_ref = self.config.q[: self.n].copy()
        return self._command(q_ref, self.reference_step(pos, rot, self.dt))

    def follow(self, q_next: np.ndarray, v: np.ndarray) -> np.ndarray:
        """One control tick along a reference solved beforehand, without solving: the IK's
        reference moves to `q_next` [rad] at `v` [rad/s] (shape (n,) each: a dry run's row,
        skills/dry_run.py) and the limited command follows it as on `step`.

        A dry run from the same state, on the same targets, solved the same QPs: its row is
        the reference `step` would compute, bit for bit (the IK integrates its reference open
        loop, the measured joints never enter it). The joint limiter still runs here, from
        the controller's setpoint as it is now (`restart_from`).

        Returns:
            As `step`: the joint angles [rad] the command starts the tick from (`velocity`
            and `acceleration` hold the rest).
        """
        import mujoco

        data = self.config.data
        q_ref = data.qpos[: self.n].copy()
        data.qpos[: self.n] = q_next
        mujoco.mj_kinematics(self._model, data)
        mujoco.mj_comPos(self._model, data)
        self._since_reset += self.dt  # the posture's ramp, as `reference_step` advances it
        self.reference_velocity = v
        self._error = None
        return self._command(q_ref, v)

    def hold(self) -> np.ndarray:
        """One control tick with the IK's reference at rest where it is (a motion's tick at
        the very start of its path): the limited command comes to it as on `step`.

        Returns:
            As `step`.
        """
        self.reference_velocity = np.zeros(self.n)
        return self._command(self.config.data.qpos[: self.n].copy(), self.reference_velocity)

    def _command(self, q_ref: np.ndarray, v: np.ndarray) -> np.ndarray:
        """The limited command over a tick on which the reference moves from `q_ref` [rad]
        at `v` [rad/s] (`step`'s return)."""
        if self._restart is not None:  # from the setpoint as it is now (see restart_from)
            q_arm, qd_arm = self._restart
            self._restart = None
            self.limiter.reset(q_arm, qd_arm)
        lim = self.limiter
        lim.step(q_ref, v)  # the reference at the start of the tick and the velocity it moves on
        self.velocity[:] = lim.start_velocity
        self.acceleration[:] = lim.acceleration
        return lim.start_position

    def reference_step(self, pos: np.ndarray, rot: np.ndarray | mink.SO3, dt: float) -> np.ndarray:
        """Advance the IK's own reference by `dt` [s] towards the world pose, without the
        limiter (what `step` does before limiting; also for dry runs of a motion).

        Returns:
            The reference's arm joint velocity over the step [rad/s] (also in
            `reference_velocity`). Shape (n,).
        """
        import mujoco

        # the target written in place (what SE3.from_rotation_and_translation + set_target
        # would build and copy): the frame task holds this solver's own SE3
        target = self._target.wxyz_xyz
        if isinstance(rot, self._so3):
            target[:4] = rot.wxyz
        else:
            mujoco.mju_mat2Quat(target[:4], np.ascontiguousarray(rot, dtype=float).ravel())
        np.subtract(pos, self.base_pos, out=target[4:])
        self.frame_task.transform_target_to_world = self._target
        # the posture error decays with a time constant, whatever the step, once ramped in
        self._since_reset += dt
        ramp = min(1.0, self._since_reset / POSTURE_RAMP_S)
        smooth = ramp * ramp * (3.0 - 2.0 * ramp)
        if isinstance(self.posture_task, self._nullspace):
            self.posture_task.gain = min(1.0, dt / POSTURE_TIME_CONSTANT_S) * smooth
        v = self._solve(dt)
        # the IK's own reference, open loop (integrate_inplace without the constraint
        # assembly of `Configuration.update`: no task here reads the equality constraints)
        model, data = self._model, self.config.data
        mujoco.mj_integratePos(model, data.qpos, v, dt)
        mujoco.mj_kinematics(model, data)
        mujoco.mj_comPos(model, data)
        self.reference_velocity = v[: self.n]
        self._error = None
        return self.reference_velocity

    def _solve(self, dt: float) -> np.ndarray:
        """mink's IK velocity over `dt` [s]: assembled in place (`IKProblem`, the same bits)
        for the tasks and limits this solver builds, by `mink.solve_ik` for any others."""
        # the tasks and limits themselves, compared by identity (none defines __eq__): an id
        # can be reused after its object is gone, and does not survive a snapshot's restore
        key = (tuple(self.tasks), tuple(self.limits), self.damping)
        if key != self._problem_key:
            from .ik_qp import IKProblem

            self._problem_key = key
            self._problem = (
                IKProblem(self.config, self.tasks, self.limits, self.damping)
                if IKProblem.supports(self.tasks, self.limits)
                else None
            )
        if self._problem is not None:
            return self._problem.solve(dt)
        import mink

        return mink.solve_ik(
            self.config, self.tasks, dt, "daqp", damping=self.damping, limits=self.limits
        )

    @property
    def lag(self) -> float:
        """Largest lag of the limited command behind the IK's own reference [rad]."""
        return float(np.max(np.abs(self.config.q[: self.n] - self.limiter.position)))

    @property
    def command(self) -> np.ndarray:
        """The limited joint command now [rad] (where the last tick's segment ends): where
        the controller's setpoint is at the next tick. Shape (n,)."""
        return self.limiter.position
