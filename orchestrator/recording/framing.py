"""Where the 3D view looks at first: the work area (the table, bins and objects, the robot), not
the floor or the room.

A scene's floor plane is drawn 4x the model's extent, so framing the model's extent leaves the
robot and objects a small part of the view. The work area is, at the start of the episode:
what moves (every body with a joint in its chain: the robot's links, a mobile base, free
objects), the scene's markers, and the fixed things they stand on or go into (each fixed
geom but planes and room-sized ones, such as walls, within `_NEAR_M` of an object or a
marker: tables, bins, pads). The eye looks at it from the front right, above, at the least
distance that keeps every corner of it inside the 3D panel (`WorkFrame.eye_for`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import mujoco
import numpy as np

if TYPE_CHECKING:
    from ..engine.context import Context

__all__ = ["FOV_Y_DEG", "VIEW_DIR", "WorkFrame", "work_frame"]

FOV_Y_DEG = 55.0
"""Vertical field of view of Rerun's 3D view [deg] (its default eye)."""
_FILL = 0.9
"""The share of the panel's height and width the work area may take at most."""
_MIN_HALF_M = 0.5
"""Least half-height framed [m]: a lone arm still shows with its surroundings, and the eye
stays ~1 m away at least."""
VIEW_DIR = np.array([1.0, -1.25, 0.85])
"""From where the eye looks at the work: in front of the robot (+x), to its right, above."""
_CENTRING_STEPS = 6
"""Rounds of moving the look target to centre the work area's projection."""
_NEAR_M = 0.5
"""A fixed geom belongs to the work area if its centre is this close to an object or a
marker in the horizontal plane [m]."""
_ROOM_SIZED_M = 1.5
"""A fixed geom with a bounding radius above this (a wall) is the room, not the work [m]."""


@dataclass(frozen=True)
class WorkFrame:
    """The work area and where the eye looks at it from, in the world frame.

    Attributes:
        points: Corners and centres that span the work area [m]. Shape (n, 3).
        center: Centre of their bounding box: where the eye looks [m]. Shape (3,).
    """

    points: np.ndarray
    center: np.ndarray

    def eye_for(self, aspect: float) -> tuple[np.ndarray, np.ndarray]:
        """The eye position and the point it looks at [m], from `VIEW_DIR`: every point of
        the work area lies within `_FILL` of a 3D panel `aspect` (width / height) wide, as
        near as that allows, the work area centred in the panel."""
        back = VIEW_DIR / np.linalg.norm(VIEW_DIR)
        forward = -back
        right = np.cross(forward, [0.0, 0.0, 1.0])
        right /= np.linalg.norm(right)
        up = np.cross(right, forward)
        tan_v = math.tan(math.radians(FOV_Y_DEG) / 2) * _FILL
        tan_h = tan_v * aspect
        target = self.center.copy()
        for _ in range(_CENTRING_STEPS):
            rel = self.points - target
            x, y, z = rel @ right, rel @ up, rel @ forward
            # a point at depth z beyond the target is inside the frustum from distance d if
            # |x| <= (d + z) tan_h and |y| <= (d + z) tan_v
            d = float(np.max(np.maximum(np.abs(x) / tan_h, np.abs(y) / tan_v) - z))
            d = max(d, _MIN_HALF_M / tan_v)
            # where the work area's projection is off centre, look that much further over
            u, v = x / (d + z), y / (d + z)
            target += d * ((u.max() + u.min()) / 2 * right + (v.max() + v.min()) / 2 * up)
        return target + back * d, target


def _box_corners(center: np.ndarray, rot: np.ndarray, half: np.ndarray) -> np.ndarray:
    signs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
    return center + (signs * half) @ rot.T


def work_frame(ctx: Context) -> WorkFrame:
    """The work area of the episode in `ctx` as it starts."""
    m, d = ctx.model, ctx.data
    moving = [b for b in range(1, m.nbody) if int(m.body_weldid[b]) != 0]
    points = [d.xpos[b].copy() for b in moving]
    # what moves, with its extent: a link's origin is at one end of it
    for g in range(m.ngeom):
        if int(m.body_weldid[m.geom_bodyid[g]]) != 0:
            r = float(m.geom_rbound[g])
            points += list(_box_corners(d.geom_xpos[g], np.eye(3), np.full(3, r)))
    markers = [np.asarray(p, dtype=np.float64) for p in ctx.world.markers.values()]
    points += markers
    objects = [d.xpos[b] for b in moving if _is_free(m, b)] + markers
    for g in range(m.ngeom):
        body = int(m.geom_bodyid[g])
        if int(m.body_weldid[body]) != 0 or m.geom_type[g] == mujoco.mjtGeom.mjGEOM_PLANE:
            continue
        if m.geom_rbound[g] > _ROOM_SIZED_M:
            continue
        center = d.geom_xpos[g]
        if not any(np.linalg.norm(center[:2] - p[:2]) <= _NEAR_M for p in objects):
            continue
        if m.geom_type[g] == mujoco.mjtGeom.mjGEOM_BOX:
            rot = d.geom_xmat[g].reshape(3, 3)
            points += list(_box_corners(center, rot, m.geom_size[g]))
        else:
            r = float(m.geom_rbound[g])
            points += list(_box_corners(center, np.eye(3), np.full(3, r)))
    if not points:
        points = [np.asarray(m.stat.center, dtype=np.float64)]
    pts = np.array(points, dtype=np.float64)
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    return WorkFrame(pts, (lo + hi) / 2.0)


def _is_free(m: mujoco.MjModel, body: int) -> bool:
    """Whether `body` hangs on a free joint (an object)."""
    n, adr = int(m.body_jntnum[body]), int(m.body_jntadr[body])
    return n > 0 and int(m.jnt_type[adr]) == mujoco.mjtJoint.mjJNT_FREE
