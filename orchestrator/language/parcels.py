"""Parcels of a sorting cell, drawn per seed: class, size, mass and pose in the pick area.

`Scenario.for_seed` turns them into ordinary scene objects (`parcel_00`, `parcel_01`, ...), so
everything that knows objects — the MuJoCo scene, contacts, perception's truth, the recording —
knows the parcels. Draws come from their own random stream of the seed.
"""

from __future__ import annotations

import math
import threading
from typing import TYPE_CHECKING

import numpy as np

from ..exceptions import ConfigError
from ..world.footprint import Box, corners, separated
from ..world.random_streams import stream
from .diagnostics import Diagnostic

if TYPE_CHECKING:
    from .sorting_scene import Parcels

__all__ = [
    "LAYOUT_TRIES",
    "PLACE_TRIES",
    "SAME_CLASS_GAP_M",
    "draw_parcels",
    "grid_shape",
    "parcel_name",
]

PLACE_TRIES = 400
"""Poses tried per parcel before the layout starts over."""

LAYOUT_TRIES = 20
"""Layouts started before the area counts as full (a crowded one can leave no room late)."""

SAME_CLASS_GAP_M = 0.01
"""Least gap between two parcels of one class, whatever `gap_m` [m]: one colour touching is one
blob to the camera (with `gap_m` 0, two red parcels side by side were seen as one unsure
parcel and left unsorted)."""

_TOUCH_GAP_M = 0.0005
"""Gap left between parcels placed touching: contact at rest, never interpenetrating [m]."""


def parcel_name(i: int, count: int) -> str:
    """`parcel_07`: zero-padded so names sort in placement order."""
    return f"parcel_{i:0{max(2, len(str(count - 1)))}d}"


_Drawn = tuple[str, list[float], float, float, float, float]


def _draw(p: Parcels, rng: np.random.Generator) -> list[_Drawn]:
    """`(class, size [m], mass [kg], x [m], y [m], yaw [rad])` per parcel: random layouts
    first; when none holds every parcel (parcels of one class never touch, so each keeps
    `gap_m` from every other: random placement fills a crowded area only to ~60 %), a grid
    of cells with the parcels jittered in them."""
    best = 0
    for _ in range(LAYOUT_TRIES):
        out = _layout(p, rng)
        if len(out) == p.count:
            return out
        best = max(best, len(out))
    grid = _grid_layout(p, rng)
    if grid is not None:
        return grid
    (sx, sy) = p.area_size_xy
    rows, cols = grid_shape(p)
    raise ConfigError(
        [
            Diagnostic(
                "<scene>",
                0,
                0,
                "scene.parcels.count",
                f"cannot place {p.count} parcels in the pick area {sx:g} x {sy:g} m with "
                f"gap_m {p.gap_m:g}: at most {best} in {LAYOUT_TRIES} random layouts, and a "
                f"grid of {rows} x {cols} cells holds {rows * cols}: use fewer parcels, a "
                "smaller gap_m or a larger area",
            )
        ]
    )


def grid_shape(p: Parcels) -> tuple[int, int]:
    """Rows and columns of the grid layout: cells that hold the largest parcel with `gap_m`
    around it, its long side along the area's longer side."""
    (sx, sy) = p.area_size_xy
    along, across = (sx, sy) if sx >= sy else (sy, sx)
    gap = max(p.gap_m, SAME_CLASS_GAP_M)  # neighbours in the grid may be of one class
    cols = int(along // (p.length_m[1] + gap))
    rows = int(across // (p.width_m[1] + gap))
    return rows, cols


def _grid_layout(p: Parcels, rng: np.random.Generator) -> list[_Drawn] | None:
    """Every parcel in its own cell of the grid (`grid_shape`), the cells drawn at random,
    each parcel shifted at random within its cell less `gap_m` (so any two stay `gap_m`
    apart, and every parcel inside the area), its long side along the area's (a turned one
    could come closer than `gap_m` to a neighbour's corner)."""
    rows, cols = grid_shape(p)
    if rows * cols < p.count:
        return None
    classes = list(p.classes)
    (ax, ay), (sx, sy) = p.area_center_xy, p.area_size_xy
    turned = sx < sy  # the long sides along y
    along, across = (sy, sx) if turned else (sx, sy)
    pitch_u, pitch_v = along / cols, across / rows
    gap = max(p.gap_m, SAME_CLASS_GAP_M)
    room_u, room_v = pitch_u - gap, pitch_v - gap
    out: list[_Drawn] = []
    for cell in rng.permutation(rows * cols)[: p.count].tolist():
        r, c = divmod(cell, cols)
        cls, size, mass = _parcel(p, classes, rng)
        u = -along / 2 + (c + 0.5) * pitch_u
        v = -across / 2 + (r + 0.5) * pitch_v
        u += float(rng.uniform(-1.0, 1.0)) * max(0.0, room_u - size[0]) / 2
        v += float(rng.uniform(-1.0, 1.0)) * max(0.0, room_v - size[1]) / 2
        x, y = (ax - v, ay + u) if turned else (ax + u, ay + v)
        out.append((cls, size, mass, x, y, math.pi / 2 if turned else 0.0))
    return out


def _parcel(
    p: Parcels, classes: list[str], rng: np.random.Generator
) -> tuple[str, list[float], float]:
    """One parcel's class, size `[length, width, height]` [m] and mass [kg], drawn in this
    order from `rng` (uniformly within `p`'s ranges)."""
    cls = classes[int(rng.integers(len(classes)))]
    size = [
        float(rng.uniform(p.length_m[0], p.length_m[1])),
        float(rng.uniform(p.width_m[0], p.width_m[1])),
        float(rng.uniform(p.height_m[0], p.height_m[1])),
    ]
    return cls, size, float(rng.uniform(p.mass_kg[0], p.mass_kg[1]))


def _layout(p: Parcels, rng: np.random.Generator) -> list[_Drawn]:
    """One try at placing every parcel; stops at the first that finds no room."""
    classes = list(p.classes)
    (ax, ay), (sx, sy) = p.area_center_xy, p.area_size_xy
    lo, hi = (ax - sx / 2, ay - sy / 2), (ax + sx / 2, ay + sy / 2)
    placed: list[Box] = []
    out: list[_Drawn] = []
    for _ in range(p.count):
        cls, size, mass = _parcel(p, classes, rng)
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
            if any(not (lo[0] <= cx <= hi[0] and lo[1] <= cy <= hi[1]) for cx, cy in corners(box)):
                continue
            # the partner it touches: no overlap; every other one: gap_m clear (for fingers),
            # and one of the same class SAME_CLASS_GAP_M at least (the camera would see one)
            if all(
                separated(box, other, 1e-6 if j == partner else _need(p, cls, out[j][0]))
                for j, other in enumerate(placed)
            ):
                placed.append(box)
                out.append((cls, size, mass, x, y, yaw))
                break
        else:
            return out
    return out


def _need(p: Parcels, cls: str, other: str) -> float:
    """The gap a free parcel of class `cls` keeps from one of class `other` [m]."""
    need = max(p.gap_m, SAME_CLASS_GAP_M) if cls == other else p.gap_m
    return need - 1e-9


def draw_parcels(p: Parcels, seed: int) -> list[tuple[str, _Drawn]]:
    """`(name, (class, size [m], mass [kg], x [m], y [m], yaw [rad]))` of each parcel of `p`
    for `seed`, from the seed's own stream for parcels.

    Raises:
        ConfigError: The parcels do not fit in the pick area.
    """
    key = (p.model_dump_json(), seed)
    drawn = _DRAWN.get(key)
    if drawn is None:  # what does not fit raises ConfigError: never kept
        rng = stream(seed, "parcels")
        drawn = [(parcel_name(i, p.count), d) for i, d in enumerate(_draw(p, rng))]
        with _DRAWN_LOCK:
            _DRAWN[key] = drawn
            if len(_DRAWN) > _DRAWN_KEPT:
                del _DRAWN[next(iter(_DRAWN))]
    return [(name, (cls, list(size), *rest)) for name, (cls, size, *rest) in drawn]


_DRAWN: dict[tuple[str, int], list[tuple[str, _Drawn]]] = {}
"""Layouts drawn in this process, by the parcels' settings and the seed: a pure function of
both, and a sorting cell's ~100 ms of rejection sampling was paid twice for every run (once
when `load_scenario` checks that the world compiles, once when the episode builds it) and
again by every batch episode or re-run of the same seed."""
_DRAWN_KEPT = 256
_DRAWN_LOCK = threading.Lock()
