"""Parcels of a sorting cell, drawn per seed: class, size, mass and pose in the pick area.

`Scenario.for_seed` turns them into ordinary scene objects (`parcel_00`, `parcel_01`, ...), so
everything that knows objects — the MuJoCo scene, contacts, perception's truth, the recording —
knows the parcels. Draws come from their own random stream of the seed.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from ..exceptions import ConfigError
from .diagnostics import Diagnostic

if TYPE_CHECKING:
    from .sorting_scene import Parcels

__all__ = ["LAYOUT_TRIES", "PLACE_TRIES", "draw_parcels", "parcel_name"]

PLACE_TRIES = 400
"""Poses tried per parcel before the layout starts over."""

LAYOUT_TRIES = 20
"""Layouts started before the area counts as full (a crowded one can leave no room late)."""

_TOUCH_GAP_M = 0.0005
"""Gap left between parcels placed touching: contact at rest, never interpenetrating [m]."""


def parcel_name(i: int, count: int) -> str:
    """`parcel_07`: zero-padded so names sort in placement order."""
    return f"parcel_{i:0{max(2, len(str(count - 1)))}d}"


_Box = tuple[float, float, float, float, float]
"""`(x, y, yaw, half length, half width)` of a parcel's footprint [m, rad]."""


def _corners(b: _Box) -> list[tuple[float, float]]:
    x, y, yaw, hx, hy = b
    c, s = math.cos(yaw), math.sin(yaw)
    return [
        (x + u * c - v * s, y + u * s + v * c)
        for u, v in ((hx, hy), (-hx, hy), (-hx, -hy), (hx, -hy))
    ]


def _gap(a: _Box, b: _Box, need: float) -> bool:
    """The footprints are at least `need` apart [m] (separated along one of their edge
    normals by that much; `need` 0: they do not overlap)."""
    if (
        math.hypot(a[0] - b[0], a[1] - b[1])
        > math.hypot(a[3], a[4]) + math.hypot(b[3], b[4]) + need
    ):
        return True  # the enclosing circles are apart: no projection needed
    pa, pb = _corners(a), _corners(b)
    for yaw in (a[2], b[2]):
        for nx, ny in ((math.cos(yaw), math.sin(yaw)), (-math.sin(yaw), math.cos(yaw))):
            da = [px * nx + py * ny for px, py in pa]
            db = [px * nx + py * ny for px, py in pb]
            if min(db) - max(da) >= need or min(da) - max(db) >= need:
                return True
    return False


_Drawn = tuple[str, list[float], float, float, float, float]


def _draw(p: Parcels, rng: np.random.Generator) -> list[_Drawn]:
    """`(class, size [m], mass [kg], x [m], y [m], yaw [rad])` per parcel."""
    for _ in range(LAYOUT_TRIES - 1):
        out = _layout(p, rng)
        if len(out) == p.count:
            return out
    out = _layout(p, rng)
    if len(out) < p.count:
        (sx, sy) = p.area_size_xy
        raise ConfigError(
            [
                Diagnostic(
                    "<scene>",
                    0,
                    0,
                    "scene.parcels.count",
                    f"cannot place {p.count} parcels in the pick area {sx:g} x {sy:g} m with "
                    f"gap_m {p.gap_m:g} (at most {len(out)} in {LAYOUT_TRIES} layouts): use "
                    "fewer parcels or a larger area",
                )
            ]
        )
    return out


def _layout(p: Parcels, rng: np.random.Generator) -> list[_Drawn]:
    """One try at placing every parcel; stops at the first that finds no room."""
    classes = list(p.classes)
    (ax, ay), (sx, sy) = p.area_center_xy, p.area_size_xy
    lo, hi = (ax - sx / 2, ay - sy / 2), (ax + sx / 2, ay + sy / 2)
    placed: list[_Box] = []
    out: list[_Drawn] = []
    for _ in range(p.count):
        cls = classes[int(rng.integers(len(classes)))]
        size = [
            float(rng.uniform(p.length_m[0], p.length_m[1])),
            float(rng.uniform(p.width_m[0], p.width_m[1])),
            float(rng.uniform(p.height_m[0], p.height_m[1])),
        ]
        mass = float(rng.uniform(p.mass_kg[0], p.mass_kg[1]))
        hx, hy = size[0] / 2, size[1] / 2
        for _ in range(PLACE_TRIES):
            touch = bool(placed) and rng.random() < p.touching
            partner = int(rng.integers(len(placed))) if touch else -1
            if touch:  # end to end with a parcel already there, along its long side
                if out[partner][0] == cls:
                    continue  # one colour end to end would look like one long parcel
                ox, oy, oyaw, ohx, _ = placed[partner]
                side = 1.0 if rng.random() < 0.5 else -1.0
                d = side * (ohx + hx + _TOUCH_GAP_M)
                x, y, yaw = ox + d * math.cos(oyaw), oy + d * math.sin(oyaw), oyaw
            else:
                x, y = (float(v) for v in rng.uniform(lo, hi))
                yaw = float(rng.uniform(-math.pi / 2, math.pi / 2))
            box = (x, y, yaw, hx, hy)
            if any(not (lo[0] <= cx <= hi[0] and lo[1] <= cy <= hi[1]) for cx, cy in _corners(box)):
                continue
            # the partner it touches: no overlap; every other one: gap_m clear (for fingers)
            if all(
                _gap(box, other, 1e-6 if j == partner else p.gap_m - 1e-9)
                for j, other in enumerate(placed)
            ):
                placed.append(box)
                out.append((cls, size, mass, x, y, yaw))
                break
        else:
            return out
    return out


def draw_parcels(p: Parcels, seed: int) -> list[tuple[str, _Drawn]]:
    """`(name, (class, size [m], mass [kg], x [m], y [m], yaw [rad]))` of each parcel of `p`
    for `seed`, from the seed's own stream for parcels.

    Raises:
        ConfigError: The parcels do not fit in the pick area.
    """
    rng = np.random.default_rng([seed, 0x9A4C])
    return [(parcel_name(i, p.count), d) for i, d in enumerate(_draw(p, rng))]
