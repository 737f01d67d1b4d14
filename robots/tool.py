"""A tool on the flange: its geometry for MuJoCo, its tip frame and payload for pinocchio.

`mount_tool(robot, tool)` returns the same robot carrying `tool` on its hand: the MuJoCo spec
gains the tool body (collision geometry, mass, a `tool_tip` site), the controller's pinocchio
model gains a `tool_tip` frame (and, unless told otherwise, the tool's mass), and the robot's
TCP becomes the tool tip for every consumer (IK, Cartesian impedance, guards). A robot with no
tool is untouched.

The wrist force/torque sensor sits on the hand, between the flange and the tool, so it feels
the tool's weight: zeroing it is part of setting up (the `zero_sensor` skill).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from .base import Robot
from .panda.model import ROBOT_CONTYPE, WORLD_CONTYPE

if TYPE_CHECKING:
    import mujoco
    import pinocchio as pin

__all__ = [
    "TIP_SITE",
    "TISSUE_CONAFFINITY",
    "TISSUE_CONTYPE",
    "Tool",
    "ToolMount",
    "mount_tool",
]

TIP_SITE = "tool_tip"
"""Name of the tip site (MuJoCo) and of the tip frame (pinocchio)."""

TISSUE_CONTYPE, TISSUE_CONAFFINITY = 4, ROBOT_CONTYPE | WORLD_CONTYPE
"""Collision bits of compliant tissue: it touches robot geoms (the tool's tip and shaft, the
links) and free objects. The shaft ends at the centre of the ball tip: it meets the tissue
once the tip is pressed in deeper than its radius (a stiffening phantom keeps the working
indentation below that, ~1.9 mm at 2 N in the surgical scenarios)."""


@dataclass(frozen=True)
class Tool:
    """A straight probe along the flange z axis: a cylindrical shaft ending in a ball tip.

    The tip frame has the hand's orientation (z along the tool, pointing out of it) and sits at
    the far end of the ball, the point that touches a surface.

    Attributes:
        name: Name of the tool (prefix of its MuJoCo body and geoms).
        mass_kg: Mass in [kg].
        length_m: From the flange to the tip along the flange z axis [m].
        shaft_radius_m: Radius of the shaft [m].
        tip_radius_m: Radius of the ball tip [m].
        com_m: Centre of mass on the axis, from the flange [m].
        friction: Sliding friction coefficient of the tip.
        rgba: Colour.
        controller_payload: Whether the controller's model knows the tool's mass (as one
            declares the end-effector load of a real arm). False leaves it as a payload
            mismatch the controller does not compensate.
    """

    name: str
    mass_kg: float
    length_m: float
    shaft_radius_m: float
    tip_radius_m: float
    com_m: float
    friction: float = 0.1
    rgba: tuple[float, float, float, float] = (0.75, 0.78, 0.82, 1.0)
    controller_payload: bool = True

    def __post_init__(self) -> None:
        if self.length_m <= 2.0 * self.tip_radius_m:
            raise ValueError(
                f"tool {self.name!r}: length_m {self.length_m} must exceed the tip diameter "
                f"{2.0 * self.tip_radius_m}"
            )
        if not 0.0 <= self.com_m <= self.length_m:
            raise ValueError(
                f"tool {self.name!r}: com_m {self.com_m} must lie on the tool [0, {self.length_m}]"
            )

    @property
    def body(self) -> str:
        """Name of the tool's MuJoCo body."""
        return f"{self.name}_tool"

    @property
    def inertia_diag(self) -> np.ndarray:
        """Principal moments about the centre of mass [kg m^2] (a solid cylinder). Shape (3,)."""
        m, r, length = self.mass_kg, self.shaft_radius_m, self.length_m
        lateral = m * (3.0 * r * r + length * length) / 12.0
        return np.array([lateral, lateral, 0.5 * m * r * r])

    def attach(self, spec: mujoco.MjSpec, parent: str) -> None:
        """Add the tool body, its geoms and the tip site to `spec` under body `parent`."""
        import mujoco

        body = spec.body(parent).add_body(name=self.body)
        body.explicitinertial = True
        body.mass = self.mass_kg
        body.ipos = [0.0, 0.0, self.com_m]
        body.inertia = self.inertia_diag.tolist()
        ball_z = self.length_m - self.tip_radius_m
        shaft = body.add_geom(
            name=f"{self.name}_shaft",
            type=mujoco.mjtGeom.mjGEOM_CYLINDER,
            fromto=[0.0, 0.0, 0.0, 0.0, 0.0, ball_z],
            size=[self.shaft_radius_m, 0.0, 0.0],
        )
        tip = body.add_geom(
            name=f"{self.name}_tip",
            type=mujoco.mjtGeom.mjGEOM_SPHERE,
            pos=[0.0, 0.0, ball_z],
            size=[self.tip_radius_m, 0.0, 0.0],
        )
        tip.condim = 3
        for geom in (shaft, tip):
            geom.contype, geom.conaffinity = ROBOT_CONTYPE, WORLD_CONTYPE
            geom.rgba = list(self.rgba)
            geom.friction = [self.friction, 0.005, 0.0001]
        body.add_site(name=TIP_SITE, pos=[0.0, 0.0, self.length_m], size=[0.002, 0.002, 0.002])

    def extend_pinocchio(self, model: pin.Model, hand_frame: str) -> pin.Model:
        """A copy of `model` with the tip frame on `hand_frame` (and the payload, if declared)."""
        import pinocchio as pin

        out = pin.Model(model)
        hand_id = out.getFrameId(hand_frame)
        hand = out.frames[hand_id]
        tip = hand.placement * pin.SE3(np.eye(3), np.array([0.0, 0.0, self.length_m]))
        out.addFrame(pin.Frame(TIP_SITE, hand.parentJoint, hand_id, tip, pin.FrameType.OP_FRAME))
        if self.controller_payload:
            local = pin.Inertia(
                self.mass_kg, np.array([0.0, 0.0, self.com_m]), np.diag(self.inertia_diag)
            )
            joint = hand.parentJoint
            out.inertias[joint] = out.inertias[joint] + hand.placement.act(local)
        return out


class ToolMount:
    """Mixin for a `Robot` subclass: the robot carries `tool` on its hand and its TCP is the
    tool tip. Build instances with `mount_tool`."""

    tcp_site: ClassVar[str] = TIP_SITE
    tcp_frame: ClassVar[str] = TIP_SITE
    hand_body: ClassVar[str]
    bare: ClassVar[type[Robot]]
    """The robot class the tool is mounted on."""

    def __init__(self, tool: Tool) -> None:
        self.tool = tool

    def __reduce__(self) -> tuple:
        # the class is made at run time (`mount_tool`): pickle (a snapshot, engine/snapshot)
        # names the robot it is mounted on, and makes the class again from it
        return (_tooled_instance, (self.bare,), vars(self))

    def build_spec(self) -> mujoco.MjSpec:
        spec: mujoco.MjSpec = super().build_spec()  # type: ignore[misc]
        self.tool.attach(spec, self.hand_body)
        return spec

    def pinocchio_model(self) -> pin.Model:
        return _tooled_pinocchio(self.bare, self.tool)


def mount_tool(robot: Robot, tool: Tool) -> Robot:
    """`robot` with `tool` on its hand: a new instance whose TCP is the tool tip.

    The reach check of motion skills (`reach_m`, from the shoulder to the TCP) grows by how far
    the tip sticks out beyond the bare hand's TCP.
    """
    base = type(robot)
    if isinstance(robot, ToolMount):
        raise ValueError(f"{base.__name__} already carries tool {robot.tool.name!r}")
    tooled: Any = _tooled_class(base)(tool)
    tooled.reach_m = base.reach_m + _extension_m(base, tool)
    return tooled


@functools.cache
def _tooled_class(base: type[Robot]) -> type[Robot]:
    return type(
        f"{base.__name__}WithTool", (ToolMount, base), {"__module__": __name__, "bare": base}
    )


def _tooled_instance(base: type[Robot]) -> Robot:
    """An empty instance of `base` with a tool (its attributes are set by pickle)."""
    cls = _tooled_class(base)
    return cls.__new__(cls)


@functools.cache
def _tooled_pinocchio(base: type[Robot], tool: Tool) -> pin.Model:
    return tool.extend_pinocchio(base().pinocchio_model(), base.hand_body)


def _extension_m(base: type[Robot], tool: Tool) -> float:
    """How much farther the tool tip is from the hand than the bare TCP [m]."""
    model = base().pinocchio_model()
    hand = model.frames[model.getFrameId(base.hand_body)].placement
    tcp = model.frames[model.getFrameId(base.tcp_frame)].placement
    bare = float(np.linalg.norm((hand.inverse() * tcp).translation))
    return max(0.0, tool.length_m - bare)
