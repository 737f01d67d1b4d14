"""The scene around the robot: floor, light, table, markers and the free objects."""

from __future__ import annotations

from typing import TYPE_CHECKING

import mujoco

from ..robots.panda.model import WORLD_CONAFFINITY, WORLD_CONTYPE
from .randomization import object_poses

if TYPE_CHECKING:
    from ..language.scenario import Scenario

__all__ = ["OBJECT_CONTACT_TIMECONST_S", "add_scene"]

OBJECT_CONTACT_TIMECONST_S = 0.005
"""Contact time constant of the free objects [s] (MuJoCo's solref; the fingers' is the same).
At MuJoCo's default 0.02 s the mixed finger-cube contact (0.0125 s) let the 20 N grip sink
1.06 mm (median of 97 pick_place seeds, 1.41 mm worst) into a wooden cube; at 0.005 s it
stays under 1 mm (bench/physical_honesty.py)."""


def add_scene(spec: mujoco.MjSpec, scenario: Scenario, seed: int) -> None:
    scene = scenario.scene
    wb = spec.worldbody
    # the floor reaches past every fixed box (a room's walls)
    extent = max(
        [2.0]
        + [
            abs(c) + s / 2
            for o in scene.obstacles
            for c, s in zip(o.center[:2], o.size[:2], strict=True)
        ]
    )
    floor = wb.add_geom(name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[extent, extent, 0.05])
    floor.rgba = [0.55, 0.58, 0.62, 1.0]
    floor.contype, floor.conaffinity = WORLD_CONTYPE, WORLD_CONAFFINITY
    light = wb.add_light(name="sun", pos=[0.5, 0.0, 2.0], dir=[0.0, 0.0, -1.0])
    del light
    table = scene.table
    half = [table.size_xy[0] / 2, table.size_xy[1] / 2, table.height / 2]
    tb = wb.add_body(name="table", pos=[*table.center_xy, table.height / 2])
    top = tb.add_geom(name="table_top", type=mujoco.mjtGeom.mjGEOM_BOX, size=half)
    top.rgba = [0.62, 0.5, 0.38, 1.0]
    top.friction = [table.friction, 0.005, 0.0001]
    top.contype, top.conaffinity = WORLD_CONTYPE, WORLD_CONAFFINITY
    for mk in scene.markers:
        g = wb.add_geom(
            name=mk.name,
            type=mujoco.mjtGeom.mjGEOM_BOX,
            pos=[*mk.xy, table.height + 0.0005],
            size=[mk.size_xy[0] / 2, mk.size_xy[1] / 2, 0.0005],
        )
        g.rgba = mk.rgba
        g.contype, g.conaffinity = 0, 0
    poses = {name: (pos, quat) for name, pos, quat in object_poses(scenario, seed)}
    for obj in scene.objects:
        pos, quat = poses[obj.name]
        body = wb.add_body(name=obj.name, pos=pos.tolist(), quat=quat.tolist())
        body.add_freejoint(name=f"{obj.name}_free")
        g = body.add_geom(
            name=f"{obj.name}_geom",
            type=mujoco.mjtGeom.mjGEOM_BOX,
            size=[s / 2 for s in obj.size],
            mass=obj.mass,
        )
        g.rgba = obj.rgba
        g.friction = [obj.friction, 0.005, 0.0001]
        g.condim = 4
        g.solref = [OBJECT_CONTACT_TIMECONST_S, 1.0]
        g.contype, g.conaffinity = WORLD_CONTYPE, WORLD_CONAFFINITY
