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
        self.v_max, self.a_max, self.j_max = v_max, a_max, j_max
        self.gain = gain
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
        # the lag behind the reference as the command follows it, half a tick late
        err = q_ref - 0.5 * dt * self._v_ref - self.position
        # Make up the lag linearly when it is small, and no faster than the joint can brake
        # from when it is large (the square-root law): a lag never turns into an overshoot.
        brake = np.sqrt(1.6 * self.a_max * np.abs(err))
        v_want = v_ref + np.sign(err) * np.minimum(self.gain * np.abs(err), brake)
        a_want = (v_want - self.velocity) / dt
        j_lim = self.j_max * dt
        a = np.clip(a_want, self.acceleration - j_lim, self.acceleration + j_lim)
        a = np.clip(a, -self.a_max, self.a_max)
        v = np.clip(self.velocity + a * dt, -self.v_max, self.v_max)
        a = (v - self.velocity) / dt
        if not np.array_equal(v, v_want):
            self.limited_ticks += 1
        self.start_position[:] = self.position
        self.start_velocity[:] = self.velocity
        self.position += 0.5 * (self.velocity + v) * dt
        self.velocity[:] = v
        self.acceleration[:] = a
        self._v_ref[:] = v_ref
