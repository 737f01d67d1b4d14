"""Arrows that keep Graphviz's routing: a polyline along `dot`'s spline where a straight line
would cross a box.

Rerun's graph view draws an edge as a straight line between two nodes. `dot` routes a long
edge around the states and labels in its way (a B-spline through its virtual nodes), so the
straight line between the same two nodes can cross them. Each arrow Rerun would draw through a
box (a state's, an outcome label's) is instead drawn along `dot`'s spline, bent at as few of
its points as keep every straight piece clear of every box. graph_drawing.py logs the bends
as invisible points of an entity of their own. Nothing here knows about Rerun.
"""

from __future__ import annotations

import heapq
import math

import numpy as np

__all__ = ["Point", "Rect", "bezier_points", "crosses", "exit_point", "route"]

Point = tuple[float, float]
Rect = tuple[float, float, float, float]

_SAMPLES = 12
"""Points sampled along each cubic piece of a spline."""
_NEAR = 80.0
"""Boxes farther than this from a route's points are not looked at [px]."""
_CLEAR = 1.0
"""A bend keeps this far outside every box it does not join [px]."""


def bezier_points(controls: list[Point]) -> list[Point]:
    """Points along a piecewise cubic Bézier spline (`dot`'s edge `pos`: a start point, then
    three control points per piece), start and end included."""
    out = [controls[0]]
    for i in range(1, len(controls) - 2, 3):
        p0, p1, p2, p3 = controls[i - 1], controls[i], controls[i + 1], controls[i + 2]
        for k in range(1, _SAMPLES + 1):
            t = k / _SAMPLES
            a, b, c, d = (1 - t) ** 3, 3 * t * (1 - t) ** 2, 3 * t * t * (1 - t), t**3
            out.append((
                a * p0[0] + b * p1[0] + c * p2[0] + d * p3[0],
                a * p0[1] + b * p1[1] + c * p2[1] + d * p3[1],
            ))  # fmt: skip
    return out


def crosses(a: Point, b: Point, boxes: list[Rect] | np.ndarray) -> bool:
    """Whether the segment a-b passes through any of `boxes` (Liang-Barsky clipping, all
    boxes at once)."""
    r = np.asarray(boxes, dtype=np.float64).reshape(-1, 4)
    if not len(r):
        return False
    dx, dy = b[0] - a[0], b[1] - a[1]
    t0, t1 = np.zeros(len(r)), np.ones(len(r))
    inside = np.ones(len(r), dtype=bool)
    for p, q in ((-dx, a[0] - r[:, 0]), (dx, r[:, 2] - a[0]), (-dy, a[1] - r[:, 1]),
                 (dy, r[:, 3] - a[1])):  # fmt: skip
        if p == 0:
            inside &= q >= 0
            continue
        t = q / p
        if p < 0:
            t0 = np.maximum(t0, t)
        else:
            t1 = np.minimum(t1, t)
    return bool(np.any(inside & (t0 <= t1)))


def route(
    start: Point, end: Point, spline: list[Point], boxes: list[Rect], ends: tuple[Rect, Rect]
) -> list[Point]:
    """The bends of an arrow from `start` to `end` (node centres) along `spline` (points from
    near `start` to near `end`): none if the straight line crosses none of `boxes` (the boxes
    it does not join); else, from `start`, each time the farthest spline point a straight
    piece reaches clear of every box (and no closer than `_CLEAR` to one), looking up to one
    cubic piece past the first it does not reach; the boxes of its own ends (`ends`: source,
    target) count but for its first and last piece."""
    if not crosses(start, end, boxes):
        return []

    def grow(r: Rect) -> Rect:
        return r[0] - _CLEAR, r[1] - _CLEAR, r[2] + _CLEAR, r[3] + _CLEAR

    points = [start, *spline, end]
    # only the boxes near the route can be in its way
    xs, ys = [p[0] for p in points], [p[1] for p in points]
    lo_x, lo_y, hi_x, hi_y = min(xs) - _NEAR, min(ys) - _NEAR, max(xs) + _NEAR, max(ys) + _NEAR
    grown = [grow(r) for r in boxes if r[0] < hi_x and r[2] > lo_x and r[1] < hi_y and r[3] > lo_y]
    src, dst = grow(ends[0]), grow(ends[1])
    last = len(points) - 1
    sets = {(a, b): np.array(grown + [src] * a + [dst] * b).reshape(-1, 4)
            for a in (0, 1) for b in (0, 1)}  # fmt: skip

    def blocked(i: int, j: int) -> bool:
        return crosses(points[i], points[j], sets[(i > 0, j < last)])

    bends: list[Point] = []
    i = 0
    while i < last:
        if blocked(i, i + 1):  # `dot`'s spline itself runs through a box here
            return _around(start, end, grown, src, dst)
        j = i + 1
        while j < last and not blocked(i, j + 1):
            j += 1
        # past the first point it cannot reach, a piece may reach one further on (round a
        # box's corner): the farthest within one more cubic piece
        j = max([k for k in range(j + 2, min(last, j + _SAMPLES) + 1) if not blocked(i, k)],
                default=j)  # fmt: skip
        if j < last:
            bends.append(points[j])
        i = j
    return bends


def _around(start: Point, end: Point, boxes: list[Rect], src: Rect, dst: Rect) -> list[Point]:
    """The bends of the shortest way from `start` to `end` round the corners of `boxes` (each
    grown by `_CLEAR` more), for an edge whose `dot` spline runs through a box: no piece
    crosses a box, and only the first and last cross their own ends'. Empty if there is none."""
    g = 2 * _CLEAR
    corners = [c for x0, y0, x1, y1 in [*boxes, src, dst]
               for c in ((x0 - g, y0 - g), (x1 + g, y0 - g), (x0 - g, y1 + g), (x1 + g, y1 + g))
               if not any(r[0] < c[0] < r[2] and r[1] < c[1] < r[3] for r in boxes)]  # fmt: skip
    nodes = [start, end, *corners]
    sets = {(a, b): np.array(boxes + [src] * a + [dst] * b).reshape(-1, 4)
            for a in (0, 1) for b in (0, 1)}  # fmt: skip

    def clear(i: int, j: int) -> bool:
        return not crosses(nodes[i], nodes[j], sets[(0 not in (i, j), 1 not in (i, j))])

    # A* over the corners, each piece checked only when the search takes it (lazily): the
    # straight distance to `end` never overestimates what is left
    back: dict[int, int] = {}
    todo: list[tuple[float, float, int, int]] = [(math.dist(start, end), 0.0, 0, -1)]
    done: set[int] = set()
    while todo:
        _, g, i, parent = heapq.heappop(todo)
        if i in done or (parent >= 0 and not clear(parent, i)):
            continue
        done.add(i)
        if parent >= 0:
            back[i] = parent
        if i == 1:
            break
        for j in range(1, len(nodes)):
            if j not in done:
                nd = g + math.dist(nodes[i], nodes[j])
                heapq.heappush(todo, (nd + math.dist(nodes[j], end), nd, j, i))
    if 1 not in back:
        return []
    path, i = [], back[1]
    while i != 0:
        path.append(nodes[i])
        i = back[i]
    return path[::-1]


def exit_point(center: Point, toward: Point, box: Rect, gap: float = 1.0) -> Point:
    """Where the segment from `center` (inside `box`) to `toward` leaves `box` grown by `gap`."""
    (cx, cy), (tx, ty) = center, toward
    dx, dy = tx - cx, ty - cy
    x0, y0, x1, y1 = box[0] - gap, box[1] - gap, box[2] + gap, box[3] + gap
    t = 1.0
    if dx > 0:
        t = min(t, (x1 - cx) / dx)
    elif dx < 0:
        t = min(t, (x0 - cx) / dx)
    if dy > 0:
        t = min(t, (y1 - cy) / dy)
    elif dy < 0:
        t = min(t, (y0 - cy) / dy)
    t = max(t, 0.0)
    return cx + t * dx, cy + t * dy
