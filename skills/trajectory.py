"""Time-parametrized motions: jerk-limited 1-D profiles (Ruckig), straight Cartesian lines."""

from __future__ import annotations

from functools import cached_property
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    import mink
    import ruckig

__all__ = ["JERK_PER_ACCEL", "CartesianLine", "Profile", "turned"]


JERK_PER_ACCEL = 50.0
"""Default jerk limit as a multiple of the acceleration limit [1/s]: the acceleration ramps
up in 20 ms (6 m/s^2 -> 300 m/s^3), far inside a Panda's Cartesian 6500 m/s^3; the joint
limiter downstream bounds the joints' own jerk. At 25 (40 ms ramps) pick_place's median cycle
was 3.03 s over 566 seeds, at 50 it is 0.045 s shorter (20 seeds, paired)."""


class Profile:
    """A time-optimal, jerk-limited motion over `distance` along one coordinate (Ruckig).

    From a start velocity `v0` and acceleration `a0` (rest by default, so a new target can be
    set mid-motion without a jump) to rest at `distance`, within the velocity, acceleration and
    jerk limits. `progress` reads the computed trajectory; it never re-plans.

    Args:
        distance: Path length (m or rad), >= 0.
        v_max: Velocity limit (per second), > 0.
        a_max: Acceleration limit (per second squared), > 0.
        j_max: Jerk limit (per second cubed), > 0; `JERK_PER_ACCEL * a_max` if None.
        v0: Velocity at the start (per second), in the direction of `distance`.
        a0: Acceleration at the start (per second squared).
    """

    def __init__(
        self,
        distance: float,
        v_max: float,
        a_max: float,
        j_max: float | None = None,
        v0: float = 0.0,
        a0: float = 0.0,
    ) -> None:
        import ruckig

        self._args = (distance, v_max, a_max, j_max, v0, a0)
        """What it was made from: a snapshot (engine/snapshot) records these as data and a
        restore computes the same trajectory again from them (it never re-plans)."""
        self.distance, self.v_max, self.a_max = float(distance), float(v_max), float(a_max)
        self.j_max = float(j_max) if j_max is not None else JERK_PER_ACCEL * self.a_max
        self._trajectory: ruckig.Trajectory | None = None
        if self.distance <= 0.0 and v0 == 0.0 and a0 == 0.0:
            self.duration = 0.0
            return
        inp = ruckig.InputParameter(1)
        inp.current_position, inp.current_velocity, inp.current_acceleration = [0.0], [v0], [a0]
        inp.target_position, inp.target_velocity = [self.distance], [0.0]
        inp.max_velocity = [self.v_max]
        inp.max_acceleration = [self.a_max]
        inp.max_jerk = [self.j_max]
        trajectory = ruckig.Trajectory(1)
        try:
            result = ruckig.Ruckig(1).calculate(inp, trajectory)
        except ruckig.RuckigError as err:  # limits it cannot work with (zero, negative)
            result = err
        if result != ruckig.Result.Working:
            raise ValueError(
                f"no jerk-limited profile over {self.distance} with v_max {self.v_max}, "
                f"a_max {self.a_max}, j_max {self.j_max}, v0 {v0}, a0 {a0}: "
                f"{str(result).splitlines()[0]}"
            )
        self._trajectory = trajectory
        self.duration = float(trajectory.duration)
        """Time to cover `distance` and come to rest [s]."""

    def __reduce__(self) -> tuple:
        # made again from its arguments (the Ruckig trajectory with it), then every other
        # attribute as it was
        return (type(self), self._args, {k: v for k, v in vars(self).items() if k != "_trajectory"})

    def progress(self, t: float) -> tuple[float, float]:
        """Normalized position s in [0, 1] and ds/dt [1/s] at time `t` [s] (clamped)."""
        if self._trajectory is None or self.distance <= 0.0:
            return 1.0, 0.0
        pos, vel, _ = self._trajectory.at_time(min(max(t, 0.0), self.duration))
        return pos[0] / self.distance, vel[0] / self.distance

    def state(self, t: float) -> tuple[float, float, float]:
        """Normalized position s, ds/dt [1/s] and d2s/dt2 [1/s^2] at time `t` [s] (clamped)."""
        if self._trajectory is None or self.distance <= 0.0:
            return 1.0, 0.0, 0.0
        pos, vel, acc = self._trajectory.at_time(min(max(t, 0.0), self.duration))
        d = self.distance
        return pos[0] / d, vel[0] / d, (acc[0] / d if t < self.duration else 0.0)


class CartesianLine:
    """A straight line in position with a synchronized geodesic in orientation.

    Both share one normalized timing law: the slower of the translational and rotational
    jerk-limited profiles sets the duration.
    """

    def __init__(
        self,
        pos0: np.ndarray,
        rot0: np.ndarray,
        pos1: np.ndarray,
        rot1: np.ndarray,
        v_max: float,
        a_max: float,
        w_max: float,
        alpha_max: float,
    ) -> None:
        import mink

        self.pos0, self.pos1 = np.asarray(pos0, float).copy(), np.asarray(pos1, float).copy()
        self.rot0 = mink.SO3.from_matrix(np.asarray(rot0, float))
        rot1_ = mink.SO3.from_matrix(np.asarray(rot1, float))
        self.delta = (self.rot0.inverse() @ rot1_).log()
        lin = Profile(float(np.linalg.norm(self.pos1 - self.pos0)), v_max, a_max)
        ang = Profile(float(np.linalg.norm(self.delta)), w_max, alpha_max)
        self.profile = lin if lin.duration >= ang.duration else ang
        self.duration = self.profile.duration

    def sample(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """Position [m] and rotation matrix at time `t` [s] after the start."""
        pos, rot = self.sample_so3(t)
        return pos, rot.as_matrix()

    def sample_so3(self, t: float) -> tuple[np.ndarray, mink.SO3]:
        """Position [m] and rotation (as an SO3, no matrix round trip) at time `t` [s]."""
        s, _ = self.profile.progress(t)
        pos = self.pos0 + s * self._span
        return pos, turned(self.rot0, s, self.delta)

    @cached_property
    def _span(self) -> np.ndarray:
        return self.pos1 - self.pos0


def turned(rot0: mink.SO3, frac: float, tangent: np.ndarray) -> mink.SO3:
    """`rot0 @ mink.SO3.exp(frac * tangent)` bit for bit (the same MuJoCo calls), without
    the intermediate SO3 and its checks: the paths' samplers call it on every IK step of a
    dry run (skills/time_scaling.py).

    Args:
        rot0: The start rotation.
        frac: Fraction of the turn.
        tangent: The whole turn as a rotation vector [rad]. Shape (3,).
    """
    import mink
    import mujoco

    axis = frac * tangent
    turn = np.empty(4)
    mujoco.mju_axisAngle2Quat(turn, axis, mujoco.mju_normalize3(axis))
    wxyz = np.empty(4)
    mujoco.mju_mulQuat(wxyz, rot0.wxyz, turn)
    return mink.SO3(wxyz=wxyz)
