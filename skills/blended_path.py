"""A Cartesian path through via points, blended at the corners, with a time-optimal timing law.

An industrial cell does not stop at a hover point: it rounds the corner and goes on. The path
is a polyline from the start through the via points to the goal; each interior corner is
replaced by a quadratic Bezier arc that starts `blend_m` before the via point and ends
`blend_m` after it (less on short segments). The timing law is the fastest one within the
speed limit, the acceleration limit along the path and the centripetal acceleration in the
arcs (speed <= sqrt(a_max / curvature)), found by a forward and a backward pass over a
2 mm grid of the path's length. The orientation turns from the start's to the goal's over the
part of the path up to the last via point (a hover point: the tool is aligned before it
descends), along the geodesic, within the angular speed and acceleration limits.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from .trajectory import turned

if TYPE_CHECKING:
    import mink

__all__ = ["BlendedPath"]

_GRID_M = 0.002
"""Spacing of the arc-length grid the timing law is computed on [m]."""


class BlendedPath:
    """Start -> via points -> goal, corners blended, timed.

    Args:
        points: The start, the via points and the goal [m]. Shape (k, 3), k >= 2.
        rot0: Start orientation (3x3).
        rot1: Goal orientation (3x3), reached at the last via point.
        v_max: Speed limit [m/s].
        a_max: Acceleration limit, along the path and centripetal [m/s^2].
        w_max: Angular speed limit [rad/s].
        alpha_max: Angular acceleration limit [rad/s^2].
        blend_m: How far before (and after) a via point the corner is rounded [m].
    """

    def __init__(
        self,
        points: np.ndarray,
        rot0: np.ndarray,
        rot1: np.ndarray,
        v_max: float,
        a_max: float,
        w_max: float,
        alpha_max: float,
        blend_m: float,
    ) -> None:
        import mink

        pts = _drop_repeats(np.asarray(points, float))
        self.rot0 = mink.SO3.from_matrix(np.asarray(rot0, float))
        self.delta = (self.rot0.inverse() @ mink.SO3.from_matrix(np.asarray(rot1, float))).log()
        xyz, curvature, via_end = _blended_polyline(pts, blend_m)
        seg = np.linalg.norm(np.diff(xyz, axis=0), axis=1)
        s = np.concatenate([[0.0], np.cumsum(seg)])
        via_len = float(s[via_end])
        self.length = float(s[-1])
        self._s, self._xyz = s, xyz
        self._columns = tuple(np.ascontiguousarray(xyz[:, i]) for i in range(3))
        """x, y, z of the samples, each contiguous: `np.interp` copies a strided column on
        every call (the dry runs of time_scaling.py sample the path hundreds of times)."""
        turn = float(np.linalg.norm(self.delta))
        # the rotation is spread over [0, s_rot]: the last via point (or the whole path)
        self.s_rot = via_len if via_len > 1e-6 else self.length
        v_lim = np.full(len(s), v_max)
        a_lim = np.full(len(s), a_max)
        with np.errstate(divide="ignore"):
            v_lim = np.minimum(v_lim, np.sqrt(a_max / np.maximum(curvature, 1e-12)))
        if turn > 1e-9 and self.s_rot > 1e-9:
            dtheta_ds = turn / self.s_rot
            rot_part = s <= self.s_rot + 1e-9
            v_lim[rot_part] = np.minimum(v_lim[rot_part], w_max / dtheta_ds)
            a_lim[rot_part] = np.minimum(a_lim[rot_part], alpha_max / dtheta_ds)
        self._v_lim, self._a_lim = v_lim, a_lim
        self._retime()
        self.turn = turn

    def _retime(self) -> None:
        self._t, self._v = _time_optimal(self._s, self._v_lim, self._a_lim)
        ds = np.diff(self._s)
        self._a = np.where(
            ds > 0, (self._v[1:] ** 2 - self._v[:-1] ** 2) / (2 * np.maximum(ds, 1e-12)), 0.0
        )
        self.duration = float(self._t[-1])

    def progress(self, t: float) -> float:
        """Arc length [m] reached at time `t` [s]: constant acceleration between grid points,
        so the speed along the path is continuous."""
        if t <= 0.0:
            return 0.0
        if t >= self.duration:
            return self.length
        i = int(np.searchsorted(self._t, t, side="right")) - 1
        tau = t - self._t[i]
        s = self._s[i] + self._v[i] * tau + 0.5 * self._a[i] * tau * tau
        return float(min(s, self._s[i + 1]))

    def limit_speed(self, s: np.ndarray, v_cap: np.ndarray, a_cap: np.ndarray) -> None:
        """Retime with further limits along the path: speed `v_cap` [m/s] and acceleration
        `a_cap` [m/s^2] at arc lengths `s` [m] (increasing), e.g. what the joints allow."""
        self._v_lim = np.minimum(self._v_lim, np.interp(self._s, s, v_cap))
        self._a_lim = np.minimum(self._a_lim, np.interp(self._s, s, a_cap))
        self._retime()

    @property
    def arc_lengths(self) -> np.ndarray:
        """The arc lengths of the grid the timing law is computed on [m] (a copy)."""
        return self._s.copy()

    @property
    def accel_limits(self) -> np.ndarray:
        """The acceleration limit along the path at each grid point [m/s^2] (a copy)."""
        return self._a_lim.copy()

    @property
    def limits(self) -> tuple[np.ndarray, np.ndarray]:
        """The speed [m/s] and acceleration [m/s^2] limits at each grid point (copies):
        `set_limits` retimes the path with them again."""
        return self._v_lim.copy(), self._a_lim.copy()

    def set_limits(self, limits: tuple[np.ndarray, np.ndarray]) -> None:
        """Retime with the speed and acceleration limits `limits` gave."""
        self._v_lim, self._a_lim = limits[0].copy(), limits[1].copy()
        self._retime()

    def cap(self, v_cap: np.ndarray, a_cap: np.ndarray) -> None:
        """Retime with the speed [m/s] and acceleration [m/s^2] at each grid point
        (`arc_lengths`) no higher than `v_cap` and `a_cap` (inf: unchanged)."""
        self._v_lim = np.minimum(self._v_lim, v_cap)
        self._a_lim = np.minimum(self._a_lim, a_cap)
        self._retime()

    def slow_between(self, z_low: float, z_high: float, v_max: float) -> float:
        """Retime with the speed capped at `v_max` [m/s] over the part of the path's last
        descent whose height lies in [`z_low`, `z_high`] [m] (a guarded approach's
        last stretch, where a finger may first meet the object): braked into it within the
        acceleration limits, constant in it, sped up again below it. Returns the length of
        path so capped [m]."""
        z = self._xyz[:, 2]
        rising = np.flatnonzero(np.diff(z) > 1e-9)
        descent = np.arange(len(z)) > (rising[-1] if len(rising) else -1)
        # the path's last descent only (its heights pass the band once there): a hover
        # point's corner, rounded 4 cm after it, ends 1 cm above a grasp 5 cm below the hover
        band = descent & (z >= z_low) & (z <= z_high)
        if not np.any(band):
            return 0.0
        self._v_lim = np.where(band, np.minimum(self._v_lim, v_max), self._v_lim)
        self._retime()
        return float(np.ptp(self._s[band]))

    def sample_so3(self, t: float) -> tuple[np.ndarray, mink.SO3]:
        """Position [m] and rotation at time `t` [s] after the start."""
        s = self.progress(t)
        grid = self._s
        pos = np.array([np.interp(s, grid, column) for column in self._columns])
        frac = 1.0 if self.s_rot <= 0.0 else min(1.0, s / self.s_rot)
        return pos, turned(self.rot0, frac, self.delta)

    def sample(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """Position [m] and rotation matrix at time `t` [s] after the start."""
        pos, rot = self.sample_so3(t)
        return pos, rot.as_matrix()


def _drop_repeats(pts: np.ndarray) -> np.ndarray:
    keep = [pts[0]]
    for p in pts[1:]:
        if np.linalg.norm(p - keep[-1]) > 1e-6:
            keep.append(p)
    if len(keep) == 1:
        keep.append(pts[-1])
    return np.array(keep)


def _blended_polyline(pts: np.ndarray, blend_m: float) -> tuple[np.ndarray, np.ndarray, int]:
    """Dense samples of the blended path [m] (shape (m, 3)), their curvature [1/m], and the
    index of the sample where the last via point's corner ends (0 without via points)."""
    n = len(pts)
    cut = np.zeros(n)  # how far from each interior corner the arc starts and ends [m]
    for i in range(1, n - 1):
        before = float(np.linalg.norm(pts[i] - pts[i - 1]))
        after = float(np.linalg.norm(pts[i + 1] - pts[i]))
        cut[i] = min(
            blend_m, 0.5 * before if i > 1 else before, 0.5 * after if i < n - 2 else after
        )
    xyz: list[np.ndarray] = [pts[:1]]
    kappa: list[np.ndarray] = [np.zeros(1)]
    count, via_end = 1, 0
    for i in range(n - 1):
        a, b = pts[i], pts[i + 1]
        d = (b - a) / np.linalg.norm(b - a)
        start, end = a + d * cut[i], b - d * cut[i + 1]
        k = max(1, math.ceil(float(np.linalg.norm(end - start)) / _GRID_M))
        xyz.append(start + np.outer(np.arange(1, k + 1) / k, end - start))
        kappa.append(np.zeros(k))
        count += k
        if i + 1 < n - 1 and cut[i + 1] <= 0.0:  # a sharp corner: passed at rest
            kappa[-1][-1] = np.inf
            via_end = count - 1
        elif i + 1 < n - 1:  # the corner at b: a quadratic Bezier end -> b -> exit
            d2 = (pts[i + 2] - b) / np.linalg.norm(pts[i + 2] - b)
            arc, curv = _bezier(end, b, b + d2 * cut[i + 1])
            xyz.append(arc)
            kappa.append(curv)
            count += len(arc)
            via_end = count - 1
    return np.vstack(xyz), np.concatenate(kappa), via_end


def _bezier(p0: np.ndarray, p1: np.ndarray, p2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Samples (excluding p0) and curvature of the quadratic Bezier p0 -> p1 -> p2."""
    chord = np.linalg.norm(p1 - p0) + np.linalg.norm(p2 - p1)
    k = max(4, math.ceil(chord / _GRID_M))
    u = np.arange(1, k + 1)[:, None] / k
    pts = (1 - u) ** 2 * p0 + 2 * (1 - u) * u * p1 + u**2 * p2
    d1 = 2 * (1 - u) * (p1 - p0) + 2 * u * (p2 - p1)
    d2 = 2 * (p2 - 2 * p1 + p0)
    cross = np.linalg.norm(np.cross(d1, d2), axis=1)
    speed = np.linalg.norm(d1, axis=1)
    return pts, cross / np.maximum(speed, 1e-12) ** 3


def _time_optimal(
    s: np.ndarray, v_lim: np.ndarray, a_lim: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Times [s] and speeds [m/s] at the arc lengths `s` [m] of the fastest rest-to-rest
    timing within `v_lim` [m/s] and `a_lim` [m/s^2] (forward pass accelerating, backward
    pass braking)."""
    n = len(s)
    ds = np.diff(s)
    v = np.minimum(v_lim, np.inf)
    v[0] = 0.0
    for i in range(n - 1):
        v[i + 1] = min(v[i + 1], math.sqrt(v[i] ** 2 + 2.0 * a_lim[i] * ds[i]))
    v[-1] = 0.0
    for i in range(n - 2, -1, -1):
        v[i] = min(v[i], math.sqrt(v[i + 1] ** 2 + 2.0 * a_lim[i] * ds[i]))
    mean = 0.5 * (v[:-1] + v[1:])
    dt = np.where(mean > 1e-9, ds / np.maximum(mean, 1e-9), 0.0)
    return np.concatenate([[0.0], np.cumsum(dt)]), v
