"""Joint limits on what the controller is commanded: velocity, acceleration and jerk.

A servo on a joint reference: each control tick the commanded velocity aims at the reference's
velocity plus a correction of the lag (`gain` x position error, and never more than the joint
could brake from before reaching the reference), and the change of command is limited in jerk,
acceleration and velocity, per joint.

The command is continuous in position and velocity: over each tick it moves with one constant
acceleration (what `step` chooses, `acceleration`) from the state the tick starts in
(`start_position`, `start_velocity`), and the controller integrates exactly that between ticks,
so it arrives where the next tick starts. A velocity jump at a tick boundary would be an
infinite acceleration for the arm to follow: the torque-controlled arm answered such jumps
with measured accelerations up to 3x the datasheet limits while its command stayed within 85 %
of them (pick_place seed 53, before this). The IK's reference is piecewise linear (one velocity
per tick); the command rounds its corners, which makes it trail a feasible reference by exactly
half a tick: that reference passes through unchanged, 5 ms late at 100 Hz. One that is not
feasible is followed as closely as the limits allow, and the lag decays once it is feasible
again.
"""

from __future__ import annotations

import numpy as np

__all__ = ["JointLimiter"]


class JointLimiter:
    """Limits a joint reference to what the robot may be commanded.

    Args:
        dt: Control period [s].
        v_max: Velocity limits [rad/s]. Shape (n,).
        a_max: Acceleration limits [rad/s^2]. Shape (n,).
        j_max: Jerk limits [rad/s^3]. Shape (n,).
        gain: Lag correction [1/s]: how fast a lag behind the reference is made up.
    """

    def __init__(
        self,
        dt: float,
        v_max: np.ndarray,
        a_max: np.ndarray,
        j_max: np.ndarray,
        gain: float = 20.0,
    ) -> None:
        self.dt = dt
        self.gain = gain
        self.v_max, self.a_max, self.j_max = v_max, a_max, j_max
        n = len(v_max)
        self.position = np.zeros(n)
        """Commanded joint angles now, at the end of the last tick [rad]. Shape (n,)."""
        self.velocity = np.zeros(n)
        """Commanded joint velocities now [rad/s]. Shape (n,)."""
        self.acceleration = np.zeros(n)
        """Commanded joint accelerations over the last tick [rad/s^2]. Shape (n,)."""
        self.start_position = np.zeros(n)
        """Commanded joint angles at the start of the last tick [rad]. Shape (n,)."""
        self.start_velocity = np.zeros(n)
        """Commanded joint velocities at the start of the last tick [rad/s]. Shape (n,)."""
        self.limited_ticks = 0
        """Ticks on which a limit changed the command."""
        self._v_ref = np.zeros(n)
        # scratch arrays: `step` allocates nothing (it runs every control tick)
        self._err, self._tmp, self._v_want = np.empty(n), np.empty(n), np.empty(n)
        self._a, self._v = np.empty(n), np.empty(n)

    @property
    def v_max(self) -> np.ndarray:
        """Velocity limits [rad/s]. Shape (n,)."""
        return self._v_max

    @v_max.setter
    def v_max(self, value: np.ndarray) -> None:
        self._v_max = np.asarray(value, float)
        self._neg_v_max = -self._v_max

    @property
    def a_max(self) -> np.ndarray:
        """Acceleration limits [rad/s^2]. Shape (n,)."""
        return self._a_max

    @a_max.setter
    def a_max(self, value: np.ndarray) -> None:
        self._a_max = np.asarray(value, float)
        self._neg_a_max = -self._a_max
        self._brake_gain = 1.6 * self._a_max

    @property
    def j_max(self) -> np.ndarray:
        """Jerk limits [rad/s^3]. Shape (n,)."""
        return self._j_max

    @j_max.setter
    def j_max(self, value: np.ndarray) -> None:
        self._j_max = np.asarray(value, float)
        self._j_lim = self._j_max * self.dt

    def reset(
        self, q: np.ndarray, qd: np.ndarray | None = None, qdd: np.ndarray | None = None
    ) -> None:
        """Start from the state `q` [rad], `qd` [rad/s], `qdd` [rad/s^2] (zero by default)."""
        self.position[:] = q
        self.velocity[:] = 0.0 if qd is None else qd
        self.acceleration[:] = 0.0 if qdd is None else qdd
        self.start_position[:] = self.position
        self.start_velocity[:] = self.velocity
        self._v_ref[:] = self.velocity

    def step(self, q_ref: np.ndarray, v_ref: np.ndarray) -> None:
        """One control tick of the reference: from `q_ref` [rad] (at the start of the tick)
        moving at `v_ref` [rad/s] over it.

        Sets the tick's segment (`start_position`, `start_velocity`, `acceleration`) and
        advances `position` and `velocity` to its end.
        """
        dt = self.dt
        err, tmp, v_want, a, v = self._err, self._tmp, self._v_want, self._a, self._v
        # the lag behind the reference as the command follows it, half a tick late
        np.multiply(0.5 * dt, self._v_ref, out=err)
        np.subtract(q_ref, err, out=err)
        err -= self.position
        # Make up the lag linearly when it is small, and no faster than the joint can brake
        # from when it is large (the square-root law): a lag never turns into an overshoot.
        # (In place, operation for operation what the expressions in the comments compute.)
        np.abs(err, out=tmp)  # brake = sqrt(1.6 a_max |err|)
        np.multiply(self._brake_gain, tmp, out=v_want)
        np.sqrt(v_want, out=v_want)
        tmp *= self.gain  # v_want = v_ref + sign(err) min(gain |err|, brake)
        np.minimum(tmp, v_want, out=v_want)
        np.sign(err, out=tmp)
        v_want *= tmp
        np.add(v_ref, v_want, out=v_want)
        np.subtract(v_want, self.velocity, out=a)  # a_want = (v_want - velocity) / dt
        a /= dt
        # a = clip(a_want, acceleration -+ j_max dt), then clip(a, -+a_max)
        np.subtract(self.acceleration, self._j_lim, out=tmp)
        np.maximum(a, tmp, out=a)
        np.add(self.acceleration, self._j_lim, out=tmp)
        np.minimum(a, tmp, out=a)
        np.maximum(a, self._neg_a_max, out=a)
        np.minimum(a, self._a_max, out=a)
        np.multiply(a, dt, out=v)  # v = clip(velocity + a dt, -+v_max)
        np.add(self.velocity, v, out=v)
        np.maximum(v, self._neg_v_max, out=v)
        np.minimum(v, self._v_max, out=v)
        np.subtract(v, self.velocity, out=a)  # a = (v - velocity) / dt
        a /= dt
        if not (v == v_want).all():
            self.limited_ticks += 1
        self.start_position[:] = self.position
        self.start_velocity[:] = self.velocity
        np.add(self.velocity, v, out=tmp)  # position += 0.5 (velocity + v) dt
        tmp *= 0.5
        tmp *= dt
        self.position += tmp
        self.velocity[:] = v
        self.acceleration[:] = a
        self._v_ref[:] = v_ref
