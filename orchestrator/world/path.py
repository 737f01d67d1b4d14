"""A planned path in the world frame: what a skill means the tool tip to follow."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

__all__ = ["PlannedPath", "TraceSpec"]


@dataclass(frozen=True)
class PlannedPath:
    """A polyline the tool tip is meant to follow, in the world frame.

    With a `normal`, deviation is measured in the plane perpendicular to it: along the normal
    the tip is force-controlled (it indents a surface by an amount the stiffness sets), so only
    the lateral distance is a path error.

    Attributes:
        points: Waypoints [m]. Shape (k, 3), k >= 2.
        normal: Unit vector along which distance does not count, or None. Shape (3,).
    """

    points: np.ndarray
    normal: np.ndarray | None = None
    _start: np.ndarray = field(init=False, repr=False)
    _seg: np.ndarray = field(init=False, repr=False)
    _len_sq: np.ndarray = field(init=False, repr=False)
    _segments: tuple[tuple[float, ...], ...] = field(init=False, repr=False)
    """Per segment, plain floats (the guard's per-step path): start, direction, length^2."""
    _n: tuple[float, float, float] | None = field(init=False, repr=False)

    def __post_init__(self) -> None:
        pts = np.array(self.points, dtype=float).reshape(-1, 3)
        if len(pts) < 2:
            raise ValueError(f"a planned path needs at least 2 points, got {len(pts)}")
        normal = None
        if self.normal is not None:
            n = np.asarray(self.normal, dtype=float)
            normal = n / np.linalg.norm(n)
            pts = pts - np.outer(pts @ normal, normal)  # project onto the plane
        seg = pts[1:] - pts[:-1]
        object.__setattr__(self, "points", pts)
        object.__setattr__(self, "normal", normal)
        object.__setattr__(self, "_start", pts[:-1])
        object.__setattr__(self, "_seg", seg)
        len_sq = np.maximum(np.einsum("ij,ij->i", seg, seg), 1e-18)
        object.__setattr__(self, "_len_sq", len_sq)
        rows = np.hstack([pts[:-1], seg, len_sq[:, None]])
        object.__setattr__(self, "_segments", tuple(tuple(r) for r in rows.tolist()))
        n3 = None if normal is None else (float(normal[0]), float(normal[1]), float(normal[2]))
        object.__setattr__(self, "_n", n3)

    @property
    def length(self) -> float:
        """Total length of the path [m]."""
        return float(np.sum(np.sqrt(self._len_sq)))

    def point_at(self, distance: float) -> np.ndarray:
        """The point `distance` [m] along the path from its start, clamped to its ends (in the
        plane perpendicular to the normal, if any). Shape (3,)."""
        lengths = np.sqrt(self._len_sq)
        for start, seg, length in zip(self._start, self._seg, lengths, strict=True):
            if distance <= length:
                return start + max(distance, 0.0) / length * seg
            distance -= length
        return self.points[-1].copy()

    def direction_at(self, distance: float) -> np.ndarray:
        """Unit direction of the path `distance` [m] from its start (of the segment there,
        clamped to the first and last). Shape (3,)."""
        lengths = np.sqrt(self._len_sq)
        index = len(lengths) - 1
        for i, length in enumerate(lengths):
            if distance < length:
                index = i
                break
            distance -= length
        return self._seg[index] / lengths[index]

    def progress(self, point: np.ndarray) -> float:
        """Distance [m] along the path from its start to the path point nearest `point`
        (shape (3,); laterally, if the path has a normal): how far along the path it is."""
        p = np.asarray(point, dtype=float)
        if self.normal is not None:
            p = p - float(p @ self.normal) * self.normal
        best, at, walked = math.inf, 0.0, 0.0
        for start, seg, len_sq in zip(self._start, self._seg, self._len_sq, strict=True):
            u = min(max(float((p - start) @ seg) / len_sq, 0.0), 1.0)
            err = p - (start + u * seg)
            d = float(err @ err)
            length = math.sqrt(len_sq)
            if d < best:
                best, at = d, float(walked + u * length)
            walked += length
        return at

    def deviation(self, point: np.ndarray) -> float:
        """Distance [m] from `point` (shape (3,)) to the nearest point of the path (laterally,
        if the path has a normal).

        Plain floats, not numpy: the `path_deviation` guard calls this every physics step and
        a path has a few segments; this costs a fraction of the small-array numpy version.
        """
        px, py, pz = point.tolist() if isinstance(point, np.ndarray) else point
        if self._n is not None:
            nx, ny, nz = self._n
            along = px * nx + py * ny + pz * nz
            px, py, pz = px - along * nx, py - along * ny, pz - along * nz
        best = math.inf
        for sx, sy, sz, dx, dy, dz, len_sq in self._segments:
            rx, ry, rz = px - sx, py - sy, pz - sz
            u = (rx * dx + ry * dy + rz * dz) / len_sq
            u = 0.0 if u < 0.0 else (1.0 if u > 1.0 else u)
            ex, ey, ez = rx - u * dx, ry - u * dy, rz - u * dz
            best = min(best, ex * ex + ey * ey + ez * ez)
        return math.sqrt(best)


@dataclass
class TraceSpec:
    """A path a contact skill is tracing, as the ground-truth probe needs it.

    Attributes:
        local_points: Waypoints in `frame` [m]. Shape (k, 3).
        frame: Position [m] (shape (3,)) and rotation (3, 3) of the frame the skill was given
            (a registered pose, an estimate of the truth), or None for the world.
        normal: Contact axis in the world (force-controlled; not a path error). Shape (3,).
        target_force_n: Normal force the skill holds [N].
        reference: Where the skill's setpoint is now, in the world [m] (updated every control
            tick). Shape (3,).
    """

    local_points: np.ndarray
    frame: tuple[np.ndarray, np.ndarray] | None
    normal: np.ndarray
    target_force_n: float
    reference: np.ndarray
