"""The scene around the robot: floor, light, table, markers and the free objects."""

from __future__ import annotations

from typing import TYPE_CHECKING

import mujoco

from ..robots.base import CONTACT_SOLIMP, CONTACT_TIMECONST_S
from ..robots.panda.model import WORLD_CONAFFINITY, WORLD_CONTYPE
from .randomization import object_poses

if TYPE_CHECKING:
    from ..language.scenario import Scenario

__all__ = ["add_scene", "harden_contacts"]


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
        g.contype, g.conaffinity = WORLD_CONTYPE, WORLD_CONAFFINITY


def harden_contacts(model: mujoco.MjModel, soft: set[int]) -> None:
    """Give every geom of `model` but those in `soft` (the tissue) the one contact softness of
    every rigid surface, `CONTACT_TIMECONST_S` and `CONTACT_SOLIMP` (robots/base.py): the
    robot's, the scene's, the conveyor's, the fault obstacles', whoever added them."""
    for g in range(model.ngeom):
        if g not in soft:
            model.geom_solref[g] = [CONTACT_TIMECONST_S, 1.0]
            model.geom_solimp[g] = CONTACT_SOLIMP
