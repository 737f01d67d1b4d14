"""Per-seed randomization of the scene: each kind draws from its own random stream, so that
adding randomness to one never moves another."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from .pose import quat_from_yaw, quat_from_ypr
from .random_streams import stream

if TYPE_CHECKING:
    from ..language.scenario import Scenario

__all__ = ["object_poses", "phantom_state"]


def object_poses(scenario: Scenario, seed: int) -> list[tuple[str, np.ndarray, np.ndarray]]:
    """Per-seed poses of the free objects: nominal + uniform offsets from the seed."""
    rng = stream(seed, "object_poses")
    out = []
    top = scenario.scene.table.height
    for obj in scenario.scene.objects:
        r = obj.randomize
        # a draw for the spot only when there are spots: other scenarios keep their poses
        spot = r.spots[int(rng.integers(len(r.spots)))] if r.spots else None
        xr, yr = (spot.x, spot.y) if spot is not None else (r.x, r.y)
        dx = rng.uniform(xr[0], xr[1])
        dy = rng.uniform(yr[0], yr[1])
        dyaw = rng.uniform(r.yaw_deg[0], r.yaw_deg[1])
        x0, y0, z0 = (*spot.xy, spot.height) if spot is not None else (*obj.xy, top)
        pos = np.array([x0 + dx, y0 + dy, z0 + obj.size[2] / 2.0])
        quat = quat_from_yaw(math.radians(obj.yaw_deg + dyaw))
        out.append((obj.name, pos, quat))
    return out


def phantom_state(scenario: Scenario, seed: int) -> tuple[np.ndarray, np.ndarray, float]:
    """Per-seed surface centre [m] (shape (3,)), orientation (quaternion w, x, y, z, shape
    (4,)) and true stiffness [N/m] of the phantom: nominal + uniform offsets from the seed (its
    own random stream; the turns are drawn after the rest, so adding them moves nothing else).

    The orientation is Rz(yaw) Ry(pitch) Rx(roll) (`Phantom`'s docstring)."""
    ph = scenario.scene.phantom
    assert ph is not None
    rng = stream(seed, "phantom_pose")
    r = ph.randomize
    dx = rng.uniform(r.x[0], r.x[1])
    dy = rng.uniform(r.y[0], r.y[1])
    scale = rng.uniform(r.stiffness_scale[0], r.stiffness_scale[1])
    turns = [
        ph.yaw_deg + rng.uniform(r.yaw_deg[0], r.yaw_deg[1]),
        ph.pitch_deg + rng.uniform(r.pitch_deg[0], r.pitch_deg[1]),
        ph.roll_deg + rng.uniform(r.roll_deg[0], r.roll_deg[1]),
    ]
    top = scenario.scene.table.height + ph.size[2]
    pos = np.array([ph.xy[0] + dx, ph.xy[1] + dy, top])
    return (
        pos,
        quat_from_ypr(*(math.radians(a) for a in turns)),
        float(ph.stiffness_n_per_m * scale),
    )
