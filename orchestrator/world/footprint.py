"""Footprints on a surface: rotated rectangles and how far apart they are.

Used where something must fit beside something else: the parcels of a sorting cell laid out
with room for the fingers (language/parcels.py), and a grasp whose fingers must clear the
object's neighbours and the walls (skills/grasp_pose.py). Plain floats: these run in loops
of a few hundred tests, where numpy's per-call overhead would be most of the cost.
"""

from __future__ import annotations

import math

__all__ = ["Box", "corners", "separated", "separation"]

Box = tuple[float, float, float, float, float]
"""`(x, y, yaw, half length, half width)` of a rectangle on the surface [m, rad]: its half
length lies along the heading `yaw`."""


def corners(b: Box) -> list[tuple[float, float]]:
    """The rectangle's four corners [m]."""
    x, y, yaw, hx, hy = b
    c, s = math.cos(yaw), math.sin(yaw)
    return [
        (x + u * c - v * s, y + u * s + v * c)
        for u, v in ((hx, hy), (-hx, hy), (-hx, -hy), (hx, -hy))
    ]


def separated(a: Box, b: Box, need: float) -> bool:
    """The rectangles are at least `need` apart [m] (separated along one of their edge
    normals by that much; `need` 0: they do not overlap)."""
    if (
        math.hypot(a[0] - b[0], a[1] - b[1])
        > math.hypot(a[3], a[4]) + math.hypot(b[3], b[4]) + need
    ):
        return True  # the enclosing circles are apart: no projection needed
    return separation(a, b) >= need


def separation(a: Box, b: Box) -> float:
    """The largest gap between the rectangles' projections on any of their edge normals [m]:
    positive, the gap a separating axis leaves; negative, they overlap (by at least that)."""
    pa, pb = corners(a), corners(b)
    best = -math.inf
    for yaw in (a[2], b[2]):
        for nx, ny in ((math.cos(yaw), math.sin(yaw)), (-math.sin(yaw), math.cos(yaw))):
            da = [px * nx + py * ny for px, py in pa]
            db = [px * nx + py * ny for px, py in pb]
            gap = max(min(db) - max(da), min(da) - max(db))
            if gap > best:  # noqa: PLR1730 (cheaper than max() in this loop)
                best = gap
    return best
