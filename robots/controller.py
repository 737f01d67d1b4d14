"""The low-level controller (the cerebellum): setpoint -> joint torques, every physics step.

It uses its own pinocchio model of the arm, loaded from the same URDF as the MuJoCo plant
with the drives' rotor inertia (`Robot.joint_armature`) configured in, never MuJoCo's ground
truth: model mismatch (link masses identified only so well, a held object, a mounted tool's
payload, joint friction) is real, and this is where it shows.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from .base import CARTESIAN_MASS, Gains, Robot

__all__ = [
    "REST_DECEL_FRACTION",
    "VELOCITY_FILTER_HZ",
    "CartesianGains",
    "ControlMode",
    "Controller",
    "default_cartesian",
]

REST_DECEL_FRACTION = 0.5
"""Fraction of the robot's acceleration limits a moving setpoint is brought to rest with. The
deceleration starts as a step: at 85 % of the limits (what the IK's commands may use) the arm
overshot it to 105-108 % on joint 3 (pick_place, 20 seeds); a stop from the typical 0.2 rad/s
that ends a motion takes 40 ms at half the limits."""
VELOCITY_FILTER_HZ = 25.0
"""Cut-off of the first-order low-pass on the joint velocities the Cartesian impedance damps
[Hz]. The encoders' velocity is a difference of quantized positions (world/sensors.py): at the
probe tip, 0.8 m out, its noise times the 140-270 N s/m of damping put ~0.1 N RMS of 30-250 Hz
noise on a 2 N tissue contact (0.13 N RMS error, seed 1003; 0.02 N with exact encoders). At
25 Hz the filter adds 5 degrees of phase at the impedance's ~3.5 Hz and leaves 0.07 N."""


class ControlMode(enum.Enum):
    """What the controller tracks."""

    JOINT = "joint"
    """Joint impedance to (q_d, qd_d) with inverse-dynamics feed-forward:
    tau = Kp (q_d - q) + Kd (qd_d - qd) + M(q) qdd_d + C(q, qd) qd + g(q).
    Between setpoints, (q_d, qd_d) advance along qdd_d every physics step (exactly, for the
    constant acceleration a setpoint holds until the next)."""
    CARTESIAN = "cartesian"
    """Cartesian impedance: tau = J^T (K e - D xdot) + g(q) + nullspace posture term, with
    K and D diagonal in the gains' frame (a surface's normal and tangents, or the base axes)
    and xdot from joint velocities low-passed at `VELOCITY_FILTER_HZ`. Meanwhile (q_d, qd_d)
    follow the measured joints and their filtered velocity, so that `hold(q_d)` or a joint move
    starting from the setpoint afterwards continues from where the arm is and as it moves (a
    velocity left over from before the Cartesian phase kicked joint 3 to 1.18x its acceleration
    limit as a move took over, surgical RETRACT)."""
    HOLD = "hold"
    """Joint impedance to the pose captured when hold() was called, zero velocity."""
    BRAKE = "brake"
    """Controlled stop (IEC 60204-1 stop category 1, like libfranka's reflex): from the
    measured state, every joint decelerates along a synchronized constant-deceleration profile
    to zero velocity (a velocity servo that never pushes a joint faster than it moves, so it
    does not drive into an obstacle it hit); then HOLD at the reached pose."""


@dataclass(frozen=True)
class CartesianGains:
    """Cartesian impedance gains, diagonal in a frame of their own.

    Attributes:
        stiffness: Translational stiffness in [N/m] and rotational in [Nm/rad] along the axes
            of `frame`. Shape (6,).
        damping: Translational damping in [N s/m] and rotational in [Nm s/rad], same axes.
            Shape (6,).
        nullspace_stiffness: Posture stiffness in the nullspace in [Nm/rad].
        frame: Rotation from the gains' axes to the base frame (its columns are the axes, e.g.
            a surface's tangents and normal), shape (3, 3); None: the base axes. The
            stiffness matrix is `R diag(k) R^T`, for translation and rotation alike.
    """

    stiffness: np.ndarray
    damping: np.ndarray
    nullspace_stiffness: float = 10.0
    frame: np.ndarray | None = None

    @classmethod
    def critically_damped(
        cls, translational: float, rotational: float, mass_kg: float = 2.0, inertia: float = 0.1
    ) -> CartesianGains:
        """Gains with damping 2 sqrt(K m) for a nominal apparent mass and inertia."""
        k = np.array([translational] * 3 + [rotational] * 3)
        m = np.array([mass_kg] * 3 + [inertia] * 3)
        return cls(stiffness=k, damping=2.0 * np.sqrt(k * m))


def default_cartesian(gains: Gains) -> CartesianGains:
    """The Cartesian impedance a robot's (or a scenario's) gains ask for when a skill sets a
    Cartesian target without gains of its own; damping, if not given, critically damped for
    the nominal apparent mass (`CARTESIAN_MASS`)."""
    k = np.array(gains.cartesian_stiffness, dtype=float)
    d = (
        2.0 * np.sqrt(k * np.array(CARTESIAN_MASS))
        if gains.cartesian_damping is None
        else np.array(gains.cartesian_damping, dtype=float)
    )
    return CartesianGains(stiffness=k, damping=d, nullspace_stiffness=gains.nullspace_stiffness)


class Controller:
    """Torque controller of one arm.

    Args:
        robot: The robot; its URDF gives the pinocchio model, its `gains` the joint and
            default Cartesian impedance (a scenario's `robot.gains`, set on the instance).
        dt: Physics step [s] (the setpoint advances by it between control ticks).
        link_mass_scale: Factor on the mass and rotational inertia of each moving body of
            the model (shape (njoints - 1,), pinocchio's joint order): the controller's model
            is identified only so well (`physics.realism.mass_mismatch`). None: exact.
    """

    def __init__(
        self, robot: Robot, dt: float = 0.002, link_mass_scale: np.ndarray | None = None
    ) -> None:
        self.robot = robot
        self.model = robot.pinocchio_model()
        if link_mass_scale is not None:
            self.model = _scaled_masses(self.model, link_mass_scale)
        self.data = self.model.createData()
        self.n = robot.n_arm
        self.kp = robot.gains.kp.astype(float).copy()
        self.kd = robot.gains.kd.astype(float).copy()
        self.effort_limit = np.asarray(self.model.effortLimit[: self.n], dtype=float).copy()
        self.tcp_id = self.model.getFrameId(robot.tcp_frame)
        self.mode = ControlMode.HOLD
        self._setpoint = np.zeros((2, self.n))
        """(q_d, qd_d) as the rows of one array: the setpoint advances with one call."""
        self.q_d = self._setpoint[0]
        """The joint angles being tracked [rad]. Shape (n,); read it, set it through `hold` or
        `set_joint_target`."""
        self.q_d[:] = robot.home
        self.qd_d = self._setpoint[1]
        self._qdd_full = np.zeros(self.model.nv)
        self.qdd_d = self._qdd_full[: self.n]
        """A view of the acceleration RNEA is given (its fingers' part stays zero)."""
        self.dt = dt
        self._advance = np.array([[0.5 * dt], [1.0]])
        """Factors on qdd_d of the setpoint's advance (q_d by its half-step term, qd_d by it)."""
        self._step = np.zeros((2, self.n))
        self._dt = np.array(dt)
        self._err = np.zeros(self.n)
        self._derr = np.zeros(self.n)
        self.pos_d = np.zeros(3)
        self.rot_d = np.eye(3)
        self.cart = default_cartesian(robot.gains)
        self.q_null = np.array(robot.home, dtype=float)
        self.qd_filtered = np.zeros(self.n)
        """Joint velocities low-passed at `VELOCITY_FILTER_HZ`, what the Cartesian impedance
        damps [rad/s]; restarted from the reading when the Cartesian mode is entered."""
        self._qd_alpha = 1.0 - float(np.exp(-2.0 * np.pi * VELOCITY_FILTER_HZ * dt))
        self._filter_fresh = True
        self.tau = np.zeros(self.n)
        self._lo = -self.effort_limit
        self.brake_left_s = 0.0
        """Time left on the braking profile [s] (0 once it has reached zero velocity)."""
        self._v_ref = np.zeros(self.n)
        self._decel = np.zeros(self.n)
        self._rest_left_s = 0.0
        self.rest_decel = REST_DECEL_FRACTION * np.asarray(robot.acceleration_limits, float)
        """Deceleration with which `hold_setpoint` brings a moving setpoint to rest [rad/s^2]."""

    # -- setpoints ----------------------------------------------------------------------
    def set_joint_target(
        self,
        q_d: np.ndarray,
        qd_d: np.ndarray | None = None,
        qdd_d: np.ndarray | None = None,
    ) -> None:
        """Track joint angles `q_d` [rad], velocity `qd_d` [rad/s], acceleration `qdd_d`
        [rad/s^2]. Shape (n,) each; omitted derivatives are zero."""
        self.mode = ControlMode.JOINT
        self._rest_left_s = 0.0
        self.q_d[:] = q_d
        self.qd_d[:] = 0.0 if qd_d is None else qd_d
        self.qdd_d[:] = 0.0 if qdd_d is None else qdd_d

    def hold(self, q: np.ndarray) -> None:
        """Hold joint angles `q` [rad] at zero velocity."""
        self.mode = ControlMode.HOLD
        self.q_d[:] = q
        self.qd_d[:] = 0.0
        self.qdd_d[:] = 0.0
        self._rest_left_s = 0.0

    def hold_setpoint(self) -> None:
        """Hold the setpoint where it is; if it still moves, where it comes to rest
        (`come_to_rest` at `rest_decel`). What a skill that keeps the arm still calls."""
        if self.mode is ControlMode.JOINT and self._rest_left_s > 0.0:
            return  # already coming to rest
        if self.mode is ControlMode.JOINT:
            self.come_to_rest(self.q_d, self.qd_d, self.rest_decel)
        else:
            self.hold(self.q_d)

    def come_to_rest(self, q: np.ndarray, qd: np.ndarray, max_decel: np.ndarray | float) -> float:
        """Hold a setpoint that is still moving: from `q` [rad] at `qd` [rad/s] it decelerates
        to rest (all joints together, the slowest at `max_decel` [rad/s^2], scalar or shape
        (n,)), tracked by the joint impedance, then HOLD where it stopped.

        `hold` at a setpoint that was moving steps its velocity to zero: the damping term
        kicks the arm (a joint at 0.15 rad/s measured 5x its datasheet acceleration for a
        step). This ends a motion as the arm can follow it.

        Returns:
            The time to rest [s] (0: already at rest, held at once).
        """
        n = self.n
        v0 = np.asarray(qd[:n], dtype=float)
        a_max = np.broadcast_to(np.asarray(max_decel, dtype=float), (n,))
        steps = int(np.ceil(float(np.max(np.abs(v0) / a_max)) / self.dt - 1e-9))
        if steps <= 0:
            self.hold(np.asarray(q[:n], dtype=float))
            return 0.0
        duration = steps * self.dt
        self.set_joint_target(np.asarray(q[:n], dtype=float), v0, -v0 / duration)
        self._rest_left_s = duration
        return duration

    def brake(self, q: np.ndarray, qd: np.ndarray, max_decel: np.ndarray | float) -> float:
        """Start a controlled stop from the measured state, then hold where it ends.

        The joints decelerate together (synchronized: all reach zero velocity at the same
        time, so the TCP keeps to its path while it stops), the slowest joint at `max_decel`,
        the others proportionally less.

        Args:
            q: Measured arm joint angles [rad]. Shape (n,) (or longer: the arm comes first).
            qd: Measured arm joint velocities [rad/s]. Same shape rules.
            max_decel: Deceleration limit per joint [rad/s^2]. Scalar or shape (n,).

        Returns:
            Duration of the deceleration [s] (0 when the arm is already still).
        """
        n = self.n
        v0 = np.asarray(qd[:n], dtype=float)
        a_max = np.broadcast_to(np.asarray(max_decel, dtype=float), (n,))
        duration = float(np.max(np.abs(v0) / a_max))
        if not np.isfinite(duration) or duration < self.dt:
            self.hold(np.asarray(q[:n], dtype=float))
            self.brake_left_s = 0.0
            return 0.0
        self.mode = ControlMode.BRAKE
        self._rest_left_s = 0.0
        self.q_d[:] = q[:n]
        self.qd_d[:] = v0
        self.qdd_d[:] = -v0 / duration
        self._v_ref = v0.copy()
        self._decel = np.abs(v0) / duration
        self.brake_left_s = duration
        return duration

    def set_cartesian_target(
        self,
        pos: np.ndarray,
        rot: np.ndarray,
        gains: CartesianGains | None = None,
        q_null: np.ndarray | None = None,
    ) -> None:
        """Cartesian impedance about the TCP pose (`pos` [m], `rot` 3x3) in the base frame."""
        if self.mode is not ControlMode.CARTESIAN:
            self._filter_fresh = True
        self.mode = ControlMode.CARTESIAN
        self.pos_d[:] = pos
        self.rot_d[:] = rot
        if gains is not None:
            self.cart = gains
        if q_null is not None:
            self.q_null[:] = q_null

    # -- the loop -----------------------------------------------------------------------
    def compute(self, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
        """Joint torques for the measured state.

        Args:
            q: Joint positions of the pinocchio model (arm then fingers). Shape (nq,).
            qd: Joint velocities. Shape (nv,).

        Returns:
            Arm torques in [Nm], clamped to the effort limits. Shape (n,).
        """
        n = self.n
        tau = self._err
        # Each numpy call on these short vectors costs ~1 us, a fresh array or a Python float
        # operand more: the same operations in the same order, into buffers, on 0-d scalars.
        if self.mode is ControlMode.JOINT:
            ff = pin.rnea(self.model, self.data, q, qd, self._qdd_full)[:n]
            np.subtract(self.q_d, q[:n], out=tau)
            np.multiply(self.kp, tau, out=tau)
            derr = np.subtract(self.qd_d, qd[:n], out=self._derr)
            np.multiply(self.kd, derr, out=derr)
            np.add(tau, derr, out=tau)
            np.add(tau, ff, out=tau)
            # the setpoint moves on between control ticks (no 100 Hz staircase), exactly
            # along the tick's constant acceleration: it arrives where the next tick starts.
            # Rows: q_d += (qd_d + dt/2 qdd_d) dt, qd_d += qdd_d dt.
            step = np.multiply(self._advance, self.qdd_d, out=self._step)
            np.add(self.qd_d, step[0], out=step[0])
            np.multiply(step, self._dt, out=step)
            np.add(self._setpoint, step, out=self._setpoint)
            if self._rest_left_s > 0.0:  # coming to rest (come_to_rest): hold once there
                self._rest_left_s -= self.dt
                if self._rest_left_s <= 1e-9:
                    self.hold(self.q_d)
        elif self.mode is ControlMode.HOLD:
            g = pin.computeGeneralizedGravity(self.model, self.data, q)[:n]
            np.subtract(self.q_d, q[:n], out=tau)
            np.multiply(self.kp, tau, out=tau)
            derr = np.multiply(self.kd, qd[:n], out=self._derr)
            np.subtract(tau, derr, out=tau)
            np.add(tau, g, out=tau)
        elif self.mode is ControlMode.CARTESIAN:
            g = pin.computeGeneralizedGravity(self.model, self.data, q)[:n]
            tau = self._cartesian(q, qd) + g
            self.q_d[:] = q[:n]
            self.qd_d[:] = self.qd_filtered
            self.qdd_d[:] = 0.0
        else:
            tau = self._brake(q, qd)
        np.minimum(tau, self.effort_limit, out=self.tau)
        np.maximum(self.tau, self._lo, out=self.tau)
        return self.tau

    def _brake(self, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
        """One step of the controlled stop: a velocity servo on the braking profile.

        Each joint's speed is brought down along its profile (`_v_ref`, shrinking by `_decel`
        every step), but never pushed: a joint already slower than its profile, or stopped
        by an obstacle, is asked for no more than its own speed, so the stop never drives the
        arm further into what it hit. Every joint still moving in its profile's direction is
        given the profile's deceleration as feed-forward, slower than the profile or not:
        given it only while faster, a joint tracking its profile crossed it every step or
        two and its torque chattered between decelerating and coasting (joint 3 at 1.05x its
        acceleration limit under a profile at half of it, the end-of-run stop of pick_place
        seed 53). No position spring during the stop; at its end, HOLD.
        """
        n = self.n
        v = qd[:n]
        ref = self._v_ref
        same = np.sign(v) == np.sign(ref)
        mag = np.minimum(np.abs(v), np.abs(ref))
        self.qd_d[:] = np.where(same, np.sign(ref) * mag, 0.0)
        self.qdd_d[:] = np.where(same, -np.sign(ref) * self._decel, 0.0)
        ff = pin.rnea(self.model, self.data, q, qd, self._qdd_full)[:n]
        tau = self.kd * (self.qd_d - v) + ff
        self.q_d[:] = q[:n]
        shrink = self._decel * self.dt
        self._v_ref = np.sign(ref) * np.maximum(np.abs(ref) - shrink, 0.0)
        self.brake_left_s -= self.dt
        if self.brake_left_s <= 1e-12:  # zero velocity reached: hold where it is
            self.brake_left_s = 0.0
            self.mode = ControlMode.HOLD
            self.qd_d[:] = 0.0
            self.qdd_d[:] = 0.0
        return tau

    @property
    def brake_profile_velocity(self) -> np.ndarray:
        """Joint velocities the braking profile allows now [rad/s] (zero outside a stop)."""
        return self._v_ref if self.mode is ControlMode.BRAKE else np.zeros(self.n)

    @property
    def clamped(self) -> np.ndarray:
        """Which joints had their torque clamped to the effort limit at the last compute()."""
        return np.abs(self.tau) >= self.effort_limit

    def tcp_pose(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """TCP position [m] and rotation of the controller's own model at `q`."""
        pin.framesForwardKinematics(self.model, self.data, q)
        frame = self.data.oMf[self.tcp_id]
        return frame.translation.copy(), frame.rotation.copy()

    def _cartesian(self, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
        n = self.n
        model, data = self.model, self.data
        pin.computeJointJacobians(model, data, q)
        pin.updateFramePlacements(model, data)
        jac = pin.getFrameJacobian(model, data, self.tcp_id, pin.LOCAL_WORLD_ALIGNED)[:, :n]
        frame = data.oMf[self.tcp_id]
        err = np.empty(6)
        err[:3] = self.pos_d - frame.translation
        err[3:] = frame.rotation @ pin.log3(frame.rotation.T @ self.rot_d)
        v = self.qd_filtered
        if self._filter_fresh:
            v[:] = qd[:n]
            self._filter_fresh = False
        else:
            v += self._qd_alpha * (qd[:n] - v)
        twist = jac @ v
        gains = self.cart
        if gains.frame is None:
            wrench = gains.stiffness * err - gains.damping * twist
        else:  # diagonal in the gains' frame: R (k * R^T e - d * R^T v), both halves
            # (rows of the (2, 3) halves times R are R^T times each half: one product each)
            r = gains.frame
            e_f = (err.reshape(2, 3) @ r).ravel()
            v_f = (twist.reshape(2, 3) @ r).ravel()
            w_f = gains.stiffness * e_f - gains.damping * v_f
            wrench = (w_f.reshape(2, 3) @ r.T).ravel()
        # Posture in the nullspace of the task: N = I - J^T (J^+)^T = I - J^+ J, the projector
        # on the right singular vectors J's rank leaves free (singular values at or below
        # 1e-3 of the largest count as zero, pinv's rcond). From one SVD, applied as
        # V_free (V_free^T tau): np.linalg.pinv plus the 7x7 product cost ~2x as much, and
        # this was a third of a surgical physics step.
        _, sv, vt = np.linalg.svd(jac)
        free = vt[np.count_nonzero(sv > 1e-3 * sv[0]) :]
        k_null = gains.nullspace_stiffness
        tau_null = k_null * (self.q_null - q[:n]) - 2.0 * np.sqrt(k_null) * v
        return jac.T @ wrench + free.T @ (free @ tau_null)


def _scaled_masses(model: pin.Model, scale: np.ndarray) -> pin.Model:
    """A copy of `model` with each body's mass and rotational inertia multiplied by `scale`
    (a uniformly denser or lighter link: its centre of mass stays where it is)."""
    scale = np.asarray(scale, dtype=float)
    if scale.shape != (model.njoints - 1,):
        raise ValueError(
            f"link_mass_scale has shape {scale.shape}, expected ({model.njoints - 1},)"
        )
    out = pin.Model(model)
    for i, k in enumerate(scale, start=1):
        body = out.inertias[i]
        out.inertias[i] = pin.Inertia(body.mass * k, body.lever, body.inertia * k)
    return out
