"""The UR5 plant: example-robot-data's ur5_robot.urdf, its joint limits set to the UR5's
datasheet, with a parallel gripper (robots/grippers.py) on its flange.

The URDF both the plant and the controller's pinocchio model are built from is generated once
per process into the temporary directory (named by its content's hash), as the mobile Panda's.
"""

from __future__ import annotations

import functools
import math
import re
from pathlib import Path
from typing import TYPE_CHECKING, ClassVar

import numpy as np

from ..assembly import assemble, write_urdf
from ..base import Datasheet, Gains, Robot
from ..exceptions import RobotError
from ..grippers import ROBOTIQ_2F85_CLASS

if TYPE_CHECKING:
    import mujoco

__all__ = ["UR5", "ur5_urdf"]

_TWO_PI = 2.0 * math.pi
_JOINTS = (
    "shoulder_pan_joint",
    "shoulder_lift_joint",
    "elbow_joint",
    "wrist_1_joint",
    "wrist_2_joint",
    "wrist_3_joint",
)
DATASHEET = Datasheet(
    position=((-_TWO_PI, _TWO_PI),) * 6,
    velocity=(math.pi, math.pi, math.pi, _TWO_PI, _TWO_PI, _TWO_PI),
    torque=(150.0, 150.0, 150.0, 28.0, 28.0, 28.0),
    source="Universal Robots, UR5 technical specifications (CB3 / e-Series datasheet): "
    "working range +-360 deg on every joint; joint speed 180 deg/s base, shoulder, elbow and "
    "360 deg/s the wrists; joint torques as in ur_description (150, 150, 150, 28, 28, 28 Nm: "
    "size 3 and size 1 joints)",
)
GRIPPER = ROBOTIQ_2F85_CLASS


def _ur_description() -> Path:
    """example-robot-data's ur_description folder (in the installed wheel)."""
    from ..panda.model import panda_urdf_path

    try:
        robots = panda_urdf_path().parents[2]
    except RobotError as exc:
        raise RobotError(f"the UR5 URDF comes from example-robot-data too: {exc}") from None
    path = robots / "ur_description"
    if not (path / "urdf" / "ur5_robot.urdf").is_file():
        raise RobotError(
            f"example-robot-data is installed but has no ur5_robot.urdf under {path};"
            " reinstall it (pip install example-robot-data)"
        )
    return path


@functools.cache
def ur5_urdf() -> Path:
    """The UR5 + gripper URDF, written once: example-robot-data's arm, its joint limits the
    datasheet's, no `world` link (the world places the base), the gripper on `tool0`."""
    text = (_ur_description() / "urdf" / "ur5_robot.urdf").read_text()
    text = re.sub(r'<link name="world"\s*/>', "", text)
    text = re.sub(r'<joint name="world_joint".*?</joint>', "", text, flags=re.S)
    # the 1 cm marker box on ee_link would stick into the gripper's palm
    text = re.sub(
        r'(<link name="ee_link">.*?)<collision>.*?</collision>', r"\1", text, count=1, flags=re.S
    )
    for i, name in enumerate(_JOINTS):
        lo, hi = DATASHEET.position[i]
        pattern = rf'(<joint name="{name}".*?<limit )[^/]*/>'
        limit = (
            f'effort="{DATASHEET.torque[i]}" lower="{lo:.10f}" upper="{hi:.10f}" '
            f'velocity="{DATASHEET.velocity[i]:.10f}"/>'
        )
        text, n = re.subn(pattern, lambda m, lim=limit: m.group(1) + lim, text, count=1, flags=re.S)
        if n != 1:
            raise RobotError(f"ur5_robot.urdf has no limit on {name}: the file changed")
    text = text.replace("</robot>", GRIPPER.urdf("tool0") + "\n</robot>")
    return write_urdf("ur5", text)


class UR5(Robot):
    """Universal Robots UR5: 6 joints (torque-controlled here; the real arm takes position,
    velocity or current commands through its controller), a Robotiq 2F-85-class parallel
    gripper on the flange."""

    name: ClassVar[str] = "ur5"
    arm_joints: ClassVar[tuple[str, ...]] = _JOINTS
    finger_joints: ClassVar[tuple[str, ...]] = GRIPPER.finger_joints
    hand_body: ClassVar[str] = GRIPPER.hand_link
    root_body: ClassVar[str] = "base_link"
    finger_bodies: ClassVar[tuple[str, str]] = GRIPPER.finger_links
    tcp_frame: ClassVar[str] = GRIPPER.tcp_link
    home: ClassVar[tuple[float, ...]] = (0.0, -1.75, 1.75, -1.571, -1.571, 0.0)
    """The hand pointing down 0.40 m ahead of the base, 0.39 m above it (elbow up)."""
    gripper_open_m: ClassVar[float] = GRIPPER.stroke_m / 2
    gripper_force_n: ClassVar[float] = GRIPPER.force_n
    gripper_speed_mps: ClassVar[float] = GRIPPER.speed_mps
    gains: Gains = Gains(
        kp=np.array([1500.0, 1500.0, 1000.0, 250.0, 150.0, 100.0]),
        kd=np.array([100.0, 100.0, 70.0, 15.0, 10.0, 6.0]),
    )
    datasheet: ClassVar[Datasheet | None] = DATASHEET
    payload_kg: ClassVar[float | None] = 5.0
    """Universal Robots, UR5 technical specifications: payload 5 kg, the tool included (here
    the parallel gripper, 0.93 kg in the model)."""
    acceleration_limits: ClassVar[tuple[float, ...]] = (10.0, 10.0, 10.0, 15.0, 15.0, 15.0)
    """[rad/s^2]. Universal Robots publishes no joint acceleration limit (the controller's
    safety limits speed, power, force and momentum): an assumption, the Panda's class of
    figures for the size 3 joints and the wrists."""
    jerk_limits: ClassVar[tuple[float, ...]] = (5000.0, 5000.0, 5000.0, 7500.0, 7500.0, 7500.0)
    """[rad/s^3], an assumption likewise (none published)."""
    shoulder_height_m: ClassVar[float] = 0.089159
    """The shoulder-lift axis above the base (ur_description's `shoulder_height`)."""
    reach_m: ClassVar[float] = 0.85 + GRIPPER.tcp_depth_m - 0.05
    """The datasheet's 850 mm reach (base axis to the flange, stretched out) plus the gripper,
    less 5 cm for the hand pointing down: a target farther than this from the shoulder is
    unreachable."""
    self_collision_bodies: ClassVar[tuple[str, ...]] = (
        "base_link",
        "shoulder_link",
        "upper_arm_link",
        "forearm_link",
        "wrist_1_link",
        "wrist_2_link",
    )
    """Links with a self-collision proxy (wrist_3's mesh, a flat flange disc, fits no capsule:
    its axis comes out shorter than MuJoCo accepts)."""
    armature: ClassVar[tuple[float, ...]] = (0.4, 0.4, 0.4, 0.1, 0.1, 0.1)
    """Rotor inertia seen at each joint [kg m^2] (`joint_armature`): a frameless motor's
    rotor through a 101:1 strain-wave gear, ~4e-5 kg m^2 x 101^2 for the size 3 joints and a
    quarter of that for the wrists (UR publishes no figure: an assumption)."""

    def urdf_path(self) -> str:
        return str(ur5_urdf())

    def build_spec(self) -> mujoco.MjSpec:
        return assemble(self, _ur_description() / "meshes" / "ur5" / "collision")

    def joint_armature(self, joint: str) -> float:
        return self.armature[self.arm_joints.index(joint)]
