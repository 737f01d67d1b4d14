"""The surgical scene: the tool on the flange, the tissue phantom, no-go zones and obstacles."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import mujoco
import numpy as np

from ..robots import Robot
from ..robots.panda.model import WORLD_CONAFFINITY, WORLD_CONTYPE
from ..robots.tool import TISSUE_CONAFFINITY, TISSUE_CONTYPE, Tool
from .pose import rotation_of, yaw_of
from .randomization import phantom_state
from .tissue import TissueLaw

if TYPE_CHECKING:
    from ..language.scenario import Scenario, ToolSpec

__all__ = [
    "ZONE_CONTYPE",
    "PhantomHandle",
    "add_phantom_scene",
    "phantom_handle",
    "set_tissue_stiffness",
    "tissue_law",
    "tool_from_spec",
]


@dataclass(frozen=True)
class PhantomHandle:
    """The tissue phantom of one episode (ground truth: perception skills add noise).

    Attributes:
        name: Its name in the scenario.
        size: Full edge lengths [m]. Shape (3,).
        surface_pos: Centre of its top surface in the world [m]. Shape (3,).
        quat: Orientation of its surface frame (z out of the tissue), quaternion (w, x, y, z).
            Shape (4,).
        stiffness_n_per_m: The true stiffness of this episode [N/m].
    """

    name: str
    size: np.ndarray
    surface_pos: np.ndarray
    quat: np.ndarray
    stiffness_n_per_m: float

    @property
    def rotation(self) -> np.ndarray:
        """Orientation of its surface frame in the world. Shape (3, 3)."""
        return rotation_of(self.quat)

    @property
    def yaw(self) -> float:
        """Heading of its x axis about world z [rad]."""
        return yaw_of(self.quat)


ZONE_CONTYPE = 16
"""Collision bit of no-go zones, set in no other geom's conaffinity: zones collide with
nothing; the no_go_zone guard measures distances to them itself."""


def tool_from_spec(spec: ToolSpec) -> Tool:
    return Tool(
        name=spec.name,
        mass_kg=spec.mass_kg,
        length_m=spec.length_m,
        shaft_radius_m=spec.shaft_radius_m,
        tip_radius_m=spec.tip_radius_m,
        com_m=spec.com_m if spec.com_m is not None else spec.length_m / 2.0,
        friction=spec.friction,
        rgba=(spec.rgba[0], spec.rgba[1], spec.rgba[2], spec.rgba[3]),
        controller_payload=spec.controller_payload,
    )


def phantom_handle(scenario: Scenario, seed: int) -> PhantomHandle | None:
    ph = scenario.scene.phantom
    if ph is None:
        return None
    pos, quat, stiffness = phantom_state(scenario, seed)
    return PhantomHandle(
        name=ph.name,
        size=np.asarray(ph.size, float),
        surface_pos=pos,
        quat=quat,
        stiffness_n_per_m=stiffness,
    )


def add_phantom_scene(spec: mujoco.MjSpec, scenario: Scenario, seed: int) -> None:
    """The phantom (a fixed compliant box), the zones (drawn, no collision) and obstacles."""
    scene = scenario.scene
    ph = scene.phantom
    body = spec.worldbody
    if ph is not None:
        surface, quat, _ = phantom_state(scenario, seed)
        centre = surface - rotation_of(quat) @ [0.0, 0.0, ph.size[2] / 2.0]
        body = spec.worldbody.add_body(name=ph.name, pos=centre.tolist(), quat=quat.tolist())
        g = body.add_geom(
            name=ph.name, type=mujoco.mjtGeom.mjGEOM_BOX, size=[v / 2 for v in ph.size]
        )
        g.rgba = ph.rgba
        g.friction = [ph.friction, 0.005, 0.0001]
        g.contype, g.conaffinity = TISSUE_CONTYPE, TISSUE_CONAFFINITY
        g.priority = 1  # its solref, solimp and friction win over the other geom's
        g.solimp = tissue_law(scenario, seed).solimp()
    for box, colliding in [(z, False) for z in scene.zones] + [(o, True) for o in scene.obstacles]:
        if box.frame == "phantom":
            assert ph is not None
            parent, pos = body, [box.center[0], box.center[1], box.center[2] + ph.size[2] / 2]
        else:
            parent, pos = spec.worldbody, box.center
        g = parent.add_geom(
            name=box.name, type=mujoco.mjtGeom.mjGEOM_BOX, pos=pos, size=[v / 2 for v in box.size]
        )
        g.rgba = box.rgba
        if colliding:
            g.contype, g.conaffinity = WORLD_CONTYPE, WORLD_CONAFFINITY
        else:  # a bit no other geom has: collides with nothing, yet compiled with the model
            g.contype, g.conaffinity = ZONE_CONTYPE, ZONE_CONTYPE


def tissue_law(scenario: Scenario, seed: int) -> TissueLaw:
    """The phantom's true force law in episode `seed` (its stiffness drawn per seed)."""
    ph = scenario.scene.phantom
    assert ph is not None
    _, _, stiffness = phantom_state(scenario, seed)
    return TissueLaw(
        stiffness=stiffness,
        damping=ph.damping_n_s_per_m,
        ratio=ph.stiffening.ratio,
        depth_m=ph.stiffening.depth_m,
    )


def set_tissue_stiffness(
    model: mujoco.MjModel, scenario: Scenario, seed: int, robot: Robot
) -> None:
    """Direct solref (-S, -B) of the phantom for its true force law (`TissueLaw`), exact
    for contacts of the TCP's body (the tool tip)."""
    ph = scenario.scene.phantom
    if ph is None:
        return
    tcp_body = int(model.site_bodyid[model.site(robot.tcp_site).id])
    inv_weight = float(model.body_invweight0[tcp_body, 0])
    model.geom_solref[model.geom(ph.name).id] = tissue_law(scenario, seed).solref(inv_weight)
