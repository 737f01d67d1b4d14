"""The mobile base's map of the room and its path planner (A* on an occupancy grid).

The map is what a real mobile robot is given (or has built): the fixed boxes of the scene —
walls, furniture, tables — from the scenario. Free objects are not in it: they are what the
robot looks for. Paths keep the robot's planning radius (its chassis and the arm folded over
it, `PLAN_RADIUS_M`) clear of every box; the last stretch to a standoff is checked against the
chassis' own rectangle instead (`footprint_clear`), which may come closer.
"""

from __future__ import annotations

import functools
import heapq
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from orchestrator.language.scenario import Scenario

__all__ = ["ESCAPE_REACH_M", "PLAN_RADIUS_M", "BaseMap", "base_map"]

PLAN_RADIUS_M = 0.55
"""Clearance of the base's centre from every box on planned paths [m]: the chassis' half
diagonal (0.39 m) plus the arm's reach beyond it at home (the hand, 0.48 m ahead of the
centre), plus 7 cm."""
CELL_M = 0.05
"""Grid resolution [m]."""
ESCAPE_REACH_M = 1.5
"""Farthest the base backs out of a tight spot before a planned path can start [m]."""
_ESCAPE_STEP_M = 0.025
_ESCAPE_DIRECTIONS = 24
"""Directions tried to back out (every 15 deg, straight back first)."""


@dataclass(frozen=True)
class Box2D:
    """An axis-aligned box's footprint on the floor: centre and half sizes [m], top height."""

    name: str
    cx: float
    cy: float
    hx: float
    hy: float
    top: float


class BaseMap:
    """The fixed boxes of a scene and a grid of where the base's centre may go.

    Args:
        boxes: The fixed boxes' footprints.
        origin: World xy of the robot's root [m] (the base joints count from there).
    """

    def __init__(self, boxes: list[Box2D], origin: tuple[float, float]) -> None:
        self.boxes = boxes
        self.origin = origin
        self._rects = [(float(b.cx), float(b.cy), float(b.hx), float(b.hy)) for b in boxes]
        """Each box's centre and half sizes as plain floats (the queries' inner loops)."""
        xs = [b.cx - b.hx for b in boxes] + [b.cx + b.hx for b in boxes] or [-2.0, 2.0]
        ys = [b.cy - b.hy for b in boxes] + [b.cy + b.hy for b in boxes] or [-2.0, 2.0]
        self.x0, self.y0 = min(xs), min(ys)
        self.nx = int(math.ceil((max(xs) - self.x0) / CELL_M)) + 1
        self.ny = int(math.ceil((max(ys) - self.y0) / CELL_M)) + 1
        gx = self.x0 + CELL_M * np.arange(self.nx)
        gy = self.y0 + CELL_M * np.arange(self.ny)
        self.free = np.ones((self.nx, self.ny), bool)
        for b in boxes:
            dx = np.maximum(np.abs(gx - b.cx) - b.hx, 0.0)[:, None]
            dy = np.maximum(np.abs(gy - b.cy) - b.hy, 0.0)[None, :]
            self.free &= dx**2 + dy**2 > PLAN_RADIUS_M**2

    def clearance(self, x: float, y: float) -> float:
        """Distance from the point (world [m]) to the nearest box [m] (negative inside)."""
        # plain floats: a numpy scalar costs several times as much per operation, same values
        x, y = float(x), float(y)
        best = math.inf
        for cx, cy, hx, hy in self._rects:
            dx, dy = abs(x - cx) - hx, abs(y - cy) - hy
            if dx > 0.0 or dy > 0.0:
                d = math.hypot(dx if dx > 0.0 else 0.0, dy if dy > 0.0 else 0.0)
            else:
                d = dx if dx >= dy else dy  # inside: the (negative) distance to the nearest side
            if d < best:  # noqa: PLR1730 (cheaper than min() in this loop)
                best = d
        return best

    def is_free(self, x: float, y: float) -> bool:
        """The base's centre may stand at (x, y) (world [m]) on a planned path."""
        return self.clearance(x, y) > PLAN_RADIUS_M

    def footprint_clear(self, x: float, y: float, yaw: float, margin: float, rect) -> bool:
        """The chassis rectangle `rect` (half length, half width [m]) at pose (x, y, yaw),
        grown by `margin` [m], touches no box (tested on points along its outline)."""
        hl, hw = rect[0] + margin, rect[1] + margin
        x, y = float(x), float(y)
        # every outline point lies within the half diagonal of the centre, and the distance
        # to the boxes changes no faster than the point moves: a centre that far clear (plus
        # a micrometre for rounding) answers for the whole outline, same answer, no loop
        if self.clearance(x, y) > math.hypot(hl, hw) + 1e-6:
            return True
        c, s = math.cos(yaw), math.sin(yaw)
        us, vs = np.linspace(-hl, hl, 9).tolist(), np.linspace(-hw, hw, 7).tolist()
        for u in us:
            for v in vs:
                if abs(u) < hl - 1e-9 and abs(v) < hw - 1e-9:
                    continue  # inside the outline: a box this small is not in a room
                if self.clearance(x + c * u - s * v, y + s * u + c * v) <= 0.0:
                    return False
        return True

    def reach_clear(self, base: np.ndarray, target: np.ndarray, half_width: float) -> bool:
        """The arm can reach from the base at `base` (world xy [m]) down to `target` (world
        x, y, z [m]): no box taller than the target's bottom lies in the corridor of
        `half_width` [m] between them (the surface the target rests on is lower)."""
        base = np.asarray(base, float)
        d = np.asarray(target[:2], float) - base
        n = np.array([-d[1], d[0]]) / (float(np.linalg.norm(d)) or 1.0)
        # the corridor's sample points, as plain floats (the same sums numpy would do)
        (bx, by), (dx, dy), (nx, ny) = base.tolist(), d.tolist(), n.tolist()
        points = [
            (bx + k * dx + side * nx, by + k * dy + side * ny)
            for k in np.linspace(0.0, 1.0, 12).tolist()
            for side in (-half_width, 0.0, half_width)
        ]
        for b, (cx, cy, hx, hy) in zip(self.boxes, self._rects, strict=True):
            if b.top <= target[2] - 0.01:
                continue
            for x, y in points:
                if abs(x - cx) < hx and abs(y - cy) < hy:
                    return False
        return True

    def escape(
        self, start: np.ndarray, yaw: float, rect, margin: float, reach_m: float = ESCAPE_REACH_M
    ) -> np.ndarray | None:
        """Where the base can back straight out to from `start` (world xy [m], heading `yaw`
        [rad]), a spot closer to the boxes than the planning radius (a standoff by the
        furniture, where planned paths cannot start), keeping its heading and the chassis
        rectangle `rect` (half length, half width [m]) `margin` [m] clear of every box all
        the way: the nearest free point of the first direction that has one within `reach_m`
        [m], trying straight back first (the way it came in), then ever further round.
        None if no direction has one (boxed in)."""
        start = np.asarray(start, float)
        back = yaw + math.pi
        turns = [0] + [k * s for k in range(1, _ESCAPE_DIRECTIONS // 2 + 1) for s in (1, -1)]
        steps = np.arange(_ESCAPE_STEP_M, reach_m + 1e-9, _ESCAPE_STEP_M).tolist()
        for k in turns[:_ESCAPE_DIRECTIONS]:
            th = back + 2.0 * math.pi * k / _ESCAPE_DIRECTIONS
            u = np.array([math.cos(th), math.sin(th)])
            for d in steps:
                p = start + d * u
                if not self.footprint_clear(p[0], p[1], yaw, margin, rect):
                    break  # the chassis would touch a box this way
                if self.is_free(*p):
                    return p
        return None

    def segment_free(self, a: np.ndarray, b: np.ndarray) -> bool:
        """Every point of the straight segment a -> b (world xy [m]) is free."""
        n = max(2, int(math.ceil(float(np.linalg.norm(b - a)) / (CELL_M / 2))))
        return all(self.is_free(*(a + (b - a) * k / n)) for k in range(n + 1))

    def plan(self, start: np.ndarray, goal: np.ndarray) -> list[np.ndarray] | None:
        """A shortest collision-free path from `start` to `goal` (world xy [m]): its corners,
        goal included, start excluded; None if there is none."""
        start, goal = np.asarray(start, float), np.asarray(goal, float)
        if self.segment_free(start, goal):
            return [goal]
        s, g = self._cell(start), self._cell(goal)
        if s is None or g is None or not self.free[g]:
            return None
        cells = self._astar(s, g)
        if cells is None:
            return None
        pts = [start] + [self._point(c) for c in cells[1:-1]] + [goal]
        return _shortcut(self, pts)[1:]

    def _cell(self, p: np.ndarray) -> tuple[int, int] | None:
        i, j = round((p[0] - self.x0) / CELL_M), round((p[1] - self.y0) / CELL_M)
        if not (0 <= i < self.nx and 0 <= j < self.ny):
            return None
        return i, j

    def _point(self, c: tuple[int, int]) -> np.ndarray:
        return np.array([self.x0 + CELL_M * c[0], self.y0 + CELL_M * c[1]])

    def _astar(self, s: tuple[int, int], g: tuple[int, int]) -> list[tuple[int, int]] | None:
        moves = [(1, 0), (-1, 0), (0, 1), (0, -1), (1, 1), (1, -1), (-1, 1), (-1, -1)]
        came: dict[tuple[int, int], tuple[int, int]] = {}
        cost = {s: 0.0}
        frontier = [(0.0, s)]
        while frontier:
            _, c = heapq.heappop(frontier)
            if c == g:
                path = [c]
                while c in came:
                    c = came[c]
                    path.append(c)
                return path[::-1]
            for di, dj in moves:
                n = (c[0] + di, c[1] + dj)
                if not (0 <= n[0] < self.nx and 0 <= n[1] < self.ny) or not self.free[n]:
                    continue
                new = cost[c] + math.hypot(di, dj)
                if new < cost.get(n, math.inf):
                    cost[n], came[n] = new, c
                    heapq.heappush(frontier, (new + math.hypot(g[0] - n[0], g[1] - n[1]), n))
        return None


def _shortcut(m: BaseMap, pts: list[np.ndarray]) -> list[np.ndarray]:
    """Drop every corner the path can go straight past (line of sight on the map)."""
    out = [pts[0]]
    i = 0
    while i < len(pts) - 1:
        j = len(pts) - 1
        while j > i + 1 and not m.segment_free(pts[i], pts[j]):
            j -= 1
        out.append(pts[j])
        i = j
    return out


@functools.lru_cache(maxsize=8)
def _cached(key: tuple) -> BaseMap:
    boxes, origin = key
    return BaseMap(list(boxes), origin)


def base_map(scenario: Scenario) -> BaseMap:
    """The map of `scenario`'s fixed boxes (its obstacles and its table), cached."""
    scene = scenario.scene
    boxes = [
        Box2D(
            o.name,
            o.center[0],
            o.center[1],
            o.size[0] / 2,
            o.size[1] / 2,
            o.center[2] + o.size[2] / 2,
        )
        for o in scene.obstacles
        if o.frame == "world"
    ]
    t = scene.table
    boxes.append(
        Box2D("table", t.center_xy[0], t.center_xy[1], t.size_xy[0] / 2, t.size_xy[1] / 2, t.height)
    )
    origin = (float(scenario.robot.base_pos[0]), float(scenario.robot.base_pos[1]))
    return _cached((tuple(boxes), origin))
