"""Where the 3D view looks at first: the work (the robot and what it handles), not the floor.

A scene's floor plane is drawn 4x the model's extent, so framing the model's extent leaves the
robot and objects a small part of the view. The work is what moves (every body with a joint in
its chain: the robot's links, a mobile base, free objects) and the scene's markers, at the
start of the episode.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from ..engine.context import Context

__all__ = ["WorkFrame", "work_frame"]

_MIN_RADIUS_M = 0.35
"""Smallest half-size framed [m]: a lone arm still shows with its surroundings."""
_VIEW_DIR = np.array([1.0, -1.25, 0.85])
"""From where the eye looks at the work: in front of the robot (+x), to its right, above."""
_DISTANCE = 3.4
"""Eye distance in radii of the framed sphere (fits it in the 3D view's field of view with
some floor around it)."""


@dataclass(frozen=True)
class WorkFrame:
    """The sphere around the work and the eye that frames it, in the world frame.

    Attributes:
        center: Centre of the work [m]. Shape (3,).
        radius: Radius of a sphere holding it [m].
        eye: Eye position [m]. Shape (3,).
    """

    center: np.ndarray
    radius: float
    eye: np.ndarray


def work_frame(ctx: Context) -> WorkFrame:
    """The work of the episode in `ctx` as it starts: moving bodies and markers."""
    m, d = ctx.model, ctx.data
    moving = [b for b in range(1, m.nbody) if int(m.body_weldid[b]) != 0]
    points = [d.xpos[b] for b in moving]
    points += [np.asarray(p, dtype=np.float64) for p in ctx.world.markers.values()]
    if not points:
        points = [np.asarray(m.stat.center, dtype=np.float64)]
    pts = np.array(points, dtype=np.float64)
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    center = (lo + hi) / 2.0
    radius = max(float(np.linalg.norm(hi - lo)) / 2.0 + 0.1, _MIN_RADIUS_M)
    direction = _VIEW_DIR / np.linalg.norm(_VIEW_DIR)
    return WorkFrame(center, radius, center + direction * _DISTANCE * radius)
