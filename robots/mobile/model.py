"""A mobile manipulator: the Panda on a holonomic base (planar x, y, yaw joints).

The robot is one URDF — a base chain (two prismatic joints and a revolute joint about z, as
an omnidirectional base moves in the plane) with the Panda fixed on top — that both the
MuJoCo plant and the controller's pinocchio model are built from, like every robot here. It
is generated from example-robot-data's panda.urdf and written once per process into the
temporary directory (named by its content's hash), so that pinocchio reads it from a file.

The base joints come first among `arm_joints`: the controller, the IK, the safety stop and
every guard (joint limits, overspeed, torque, collision) treat them like the arm's. See
docs/robots.md for why (and why not TIAGo).
"""

from __future__ import annotations

import functools
import math
import re
from pathlib import Path
from typing import TYPE_CHECKING, ClassVar

import numpy as np

from ..assembly import write_urdf
from ..base import Datasheet, Gains
from ..panda.model import ROBOT_CONAFFINITY, ROBOT_CONTYPE, Panda, panda_urdf_path

if TYPE_CHECKING:
    import mujoco

__all__ = ["BASE", "BaseGeometry", "MobilePanda", "mobile_panda_urdf"]


class BaseGeometry:
    """Dimensions, mass and limits of the holonomic base (a Ridgeback / TIAGo-class platform)."""

    length_m = 0.60
    width_m = 0.50
    height_m = 0.20
    """Box of the chassis [m]."""
    clearance_m = 0.02
    """Gap between the chassis and the floor [m]: the wheels are not modelled, so the chassis
    never touches the floor (the collision guard counts every contact of a robot body)."""
    mass_kg = 45.0
    arm_mount_x_m = 0.12
    """The Panda's base sits this far forward of the base's centre [m]."""
    mast_x_m = -0.22
    mast_height_m = 1.35
    """A thin camera mast at the back of the chassis, this tall above its top [m]."""
    speed_mps = 0.5
    yaw_rate_rad_s = 1.0
    accel_mps2 = 1.0
    yaw_accel_rad_s2 = 2.0
    force_n = 400.0
    """Largest traction force of the drive [N] (45 kg + the 18 kg arm at ~6 m/s^2)."""
    yaw_torque_nm = 150.0
    travel_m = 6.0
    """Range of each planar joint about the start pose [m] (a room; the joint limits guard
    fires beyond it)."""
    yaw_range_rad = 100.0 * math.pi
    """Range of the yaw joint on each side [rad]: 50 turns either way (a base turns without
    end; the joint limits guard needs a finite range)."""

    @property
    def top_m(self) -> float:
        """Height of the chassis top (where the arm is mounted) above the floor [m]."""
        return self.clearance_m + self.height_m


BASE = BaseGeometry()

_BASE_JOINTS = ("base_x_joint", "base_y_joint", "base_yaw_joint")


def _inertial(mass: float, diag: tuple[float, float, float], z: float = 0.0) -> str:
    ixx, iyy, izz = diag
    return (
        f'<inertial><origin xyz="0 0 {z}" rpy="0 0 0"/><mass value="{mass}"/>'
        f'<inertia ixx="{ixx:.5g}" ixy="0" ixz="0" iyy="{iyy:.5g}" iyz="0" izz="{izz:.5g}"/>'
        "</inertial>"
    )


def _box(xyz: tuple[float, float, float], size: tuple[float, float, float]) -> str:
    return (
        f'<collision><origin xyz="{xyz[0]} {xyz[1]} {xyz[2]}" rpy="0 0 0"/>'
        f'<geometry><box size="{size[0]} {size[1]} {size[2]}"/></geometry></collision>'
    )


def _joint(name: str, kind: str, parent: str, child: str, axis: str, lim: tuple) -> str:
    lo, hi, effort, velocity = lim
    return (
        f'<joint name="{name}" type="{kind}"><parent link="{parent}"/><child link="{child}"/>'
        f'<axis xyz="{axis}"/><limit lower="{lo:.6f}" upper="{hi:.6f}" effort="{effort}"'
        f' velocity="{velocity}"/></joint>'
    )


def _base_chain() -> str:
    """URDF of the base: the planar joints, the chassis and mast, the fixed arm mount."""
    b = BASE
    tiny = _inertial(0.01, (1e-5, 1e-5, 1e-5))
    lx, ly, lz, m = b.length_m, b.width_m, b.height_m, b.mass_kg
    zc = b.clearance_m + lz / 2.0
    diag = (m * (ly**2 + lz**2) / 12.0, m * (lx**2 + lz**2) / 12.0, m * (lx**2 + ly**2) / 12.0)
    mast = _box((b.mast_x_m, 0.0, b.top_m + b.mast_height_m / 2), (0.06, 0.06, b.mast_height_m))
    chassis = _box((0.0, 0.0, zc), (lx, ly, lz))
    planar = (-b.travel_m, b.travel_m, b.force_n, b.speed_mps)
    yaw = (-b.yaw_range_rad, b.yaw_range_rad, b.yaw_torque_nm, b.yaw_rate_rad_s)
    return "\n".join(
        [
            f'<link name="base_origin">{tiny}</link>',
            f'<link name="base_x_link">{tiny}</link>',
            f'<link name="base_y_link">{tiny}</link>',
            f'<link name="base_link">{chassis}{mast}{_inertial(m, diag, zc)}</link>',
            _joint("base_x_joint", "prismatic", "base_origin", "base_x_link", "1 0 0", planar),
            _joint("base_y_joint", "prismatic", "base_x_link", "base_y_link", "0 1 0", planar),
            _joint("base_yaw_joint", "revolute", "base_y_link", "base_link", "0 0 1", yaw),
            '<joint name="base_to_panda" type="fixed"><parent link="base_link"/>'
            f'<child link="panda_link0"/><origin xyz="{b.arm_mount_x_m} 0 {b.top_m}"'
            ' rpy="0 0 0"/></joint>',
            "",
        ]
    )


@functools.cache
def mobile_panda_urdf() -> Path:
    """The mobile Panda's URDF: the base chain + example-robot-data's Panda, written once.

    Returns:
        Path of the generated file (in the temporary directory, named by its content).
    """
    panda = panda_urdf_path().read_text()
    text = re.sub(r'<robot name="panda"', '<robot name="mobile_panda"', panda, count=1)
    first_link = text.index("<link ")
    text = text[:first_link] + _base_chain() + text[first_link:]
    return write_urdf("mobile_panda", text)


class MobilePanda(Panda):
    """The Panda on a holonomic base: 3 velocity-servoed base joints + 7 torque-controlled
    arm joints (all in `arm_joints`, base first), the Panda's gripper, a camera mast.

    The base joints are driven by the same joint servo as the arm; for them it is a velocity
    servo (damping dominates: 900 N s/m against 300 N/m) with inverse-dynamics feed-forward,
    fed profiles within the base's speed (0.5 m/s, 1 rad/s) and acceleration (1 m/s^2,
    2 rad/s^2) limits — what a real base's drive controller does with velocity commands.
    """

    name: ClassVar[str] = "mobile_panda"
    base_joints: ClassVar[tuple[str, ...]] = _BASE_JOINTS
    arm_joints: ClassVar[tuple[str, ...]] = (*_BASE_JOINTS, *Panda.arm_joints)
    root_body: ClassVar[str] = "base_origin"
    base_body: ClassVar[str] = "base_link"
    """The chassis (cameras on the robot's base mount here)."""
    home: ClassVar[tuple[float, ...]] = (0.0, 0.0, 0.0, *Panda.home)
    gains: Gains = Gains(
        kp=np.array([300.0, 300.0, 100.0, *Panda.gains.kp]),
        kd=np.array([900.0, 900.0, 150.0, *Panda.gains.kd]),
    )
    datasheet: ClassVar[Datasheet | None] = Datasheet(
        position=(
            (-BASE.travel_m, BASE.travel_m),
            (-BASE.travel_m, BASE.travel_m),
            (-BASE.yaw_range_rad, BASE.yaw_range_rad),
            *(Panda.datasheet.position if Panda.datasheet else ()),
        ),
        velocity=(
            BASE.speed_mps,
            BASE.speed_mps,
            BASE.yaw_rate_rad_s,
            *(Panda.datasheet.velocity if Panda.datasheet else ()),
        ),
        torque=(
            BASE.force_n,
            BASE.force_n,
            BASE.yaw_torque_nm,
            *(Panda.datasheet.torque if Panda.datasheet else ()),
        ),
        source="the base: `BaseGeometry` (a Ridgeback / TIAGo-class platform); the arm: "
        + (Panda.datasheet.source if Panda.datasheet else ""),
    )
    acceleration_limits: ClassVar[tuple[float, ...]] = (
        BASE.accel_mps2,
        BASE.accel_mps2,
        BASE.yaw_accel_rad_s2,
        *Panda.acceleration_limits,
    )
    jerk_limits: ClassVar[tuple[float, ...]] = (10.0, 10.0, 20.0, *Panda.jerk_limits)
    joint_friction_nm: ClassVar[tuple[float, ...] | None] = (
        8.0,
        8.0,
        3.0,
        *(Panda.joint_friction_nm or ()),
    )
    """Rolling resistance of the base [N, N, Nm] (~1.3 % of its weight), then the Panda's."""
    joint_damping_nms: ClassVar[tuple[float, ...] | None] = (
        5.0,
        5.0,
        2.0,
        *(Panda.joint_damping_nms or ()),
    )
    shoulder_height_m: ClassVar[float] = BASE.top_m + Panda.shoulder_height_m
    self_collision_bodies: ClassVar[tuple[str, ...]] = Panda.self_collision_bodies

    def urdf_path(self) -> str:
        return str(mobile_panda_urdf())

    def joint_armature(self, joint: str) -> float:
        return 0.0 if joint in self.base_joints else self.armature

    def build_spec(self) -> mujoco.MjSpec:
        spec = super().build_spec()
        for geom in spec.body(self.base_body).geoms:
            geom.contype, geom.conaffinity = ROBOT_CONTYPE, ROBOT_CONAFFINITY
            geom.rgba = [0.25, 0.27, 0.3, 1.0]
        return spec

    def shoulder(self, q: np.ndarray, base_pos: np.ndarray) -> np.ndarray:
        """World position of the arm's first pitch axis [m] at joint angles `q` (base first).

        Args:
            q: Joint angles, `arm_joints` order [m, rad]. Shape (n_arm,).
            base_pos: Where the robot's root stands in the world [m]. Shape (3,).
        """
        x, y, yaw = float(q[0]), float(q[1]), float(q[2])
        mx = BASE.arm_mount_x_m
        return np.asarray(base_pos, float) + [
            x + mx * math.cos(yaw),
            y + mx * math.sin(yaw),
            self.shoulder_height_m,
        ]
