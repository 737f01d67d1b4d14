"""Time-parametrized motions: trapezoidal velocity profiles, straight Cartesian lines."""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import mink
import numpy as np

__all__ = ["CartesianLine", "Trapezoid"]


@dataclass(frozen=True)
class Trapezoid:
    """A rest-to-rest trapezoidal (or triangular) velocity profile over `distance`.

    Attributes:
        distance: Path length (m or rad), >= 0.
        v_max: Velocity limit (per second), > 0.
        a_max: Acceleration limit (per second squared), > 0.
    """

    distance: float
    v_max: float
    a_max: float

    @cached_property
    def _cruise(self) -> tuple[float, float]:
        t_acc = self.v_max / self.a_max
        if self.a_max * t_acc * t_acc >= self.distance:  # never reaches v_max
            t_acc = math.sqrt(self.distance / self.a_max)
            return t_acc, 0.0
        return t_acc, (self.distance - self.a_max * t_acc * t_acc) / self.v_max

    @property
    def duration(self) -> float:
        """Time to cover `distance` [s]."""
        t_acc, t_cruise = self._cruise
        return 2.0 * t_acc + t_cruise

    def progress(self, t: float) -> tuple[float, float]:
        """Normalized position s in [0, 1] and ds/dt at time `t` [s]."""
        if self.distance <= 0.0:
            return 1.0, 0.0
        t_acc, t_cruise = self._cruise
        v_peak = self.a_max * t_acc
        total = 2.0 * t_acc + t_cruise
        t = min(max(t, 0.0), total)
        if t < t_acc:
            pos, vel = 0.5 * self.a_max * t * t, self.a_max * t
        elif t < t_acc + t_cruise:
            pos = 0.5 * self.a_max * t_acc * t_acc + v_peak * (t - t_acc)
            vel = v_peak
        else:
            tr = total - t
            pos, vel = self.distance - 0.5 * self.a_max * tr * tr, self.a_max * tr
        return pos / self.distance, vel / self.distance


class CartesianLine:
    """A straight line in position with a synchronized geodesic in orientation.

    Both share one normalized timing law: the slower of the translational and rotational
    trapezoids sets the duration.
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
        self.pos0, self.pos1 = np.asarray(pos0, float).copy(), np.asarray(pos1, float).copy()
        self.rot0 = mink.SO3.from_matrix(np.asarray(rot0, float))
        rot1_ = mink.SO3.from_matrix(np.asarray(rot1, float))
        self.delta = (self.rot0.inverse() @ rot1_).log()
        lin = Trapezoid(float(np.linalg.norm(self.pos1 - self.pos0)), v_max, a_max)
        ang = Trapezoid(float(np.linalg.norm(self.delta)), w_max, alpha_max)
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
        return pos, self.rot0 @ mink.SO3.exp(s * self.delta)

    @cached_property
    def _span(self) -> np.ndarray:
        return self.pos1 - self.pos0
