"""The Franka Panda plant, assembled with MjSpec from example-robot-data's URDF."""

from __future__ import annotations

import functools
import importlib.metadata
import math
import os
from pathlib import Path
from typing import TYPE_CHECKING, ClassVar

import numpy as np

from ..assembly import assemble
from ..base import (
    ROBOT_CONAFFINITY,
    ROBOT_CONTYPE,
    WORLD_CONAFFINITY,
    WORLD_CONTYPE,
    Datasheet,
    Gains,
    Robot,
)
from ..exceptions import RobotError

if TYPE_CHECKING:
    import mujoco

__all__ = [
    "ROBOT_CONAFFINITY",
    "ROBOT_CONTYPE",
    "WORLD_CONAFFINITY",
    "WORLD_CONTYPE",
    "Panda",
    "panda_urdf_path",
]

_URDF_IN_WHEEL = "cmeel.prefix/share/example-robot-data/robots/panda_description/urdf/panda.urdf"
_ENV_OVERRIDE = "ORCHESTRATOR_PANDA_URDF"


@functools.cache
def panda_urdf_path() -> Path:
    """Locate panda.urdf inside the installed `example-robot-data` distribution."""
    if override := os.environ.get(_ENV_OVERRIDE):
        return Path(override)
    try:
        dist = importlib.metadata.distribution("example-robot-data")
    except importlib.metadata.PackageNotFoundError as exc:
        raise RobotError(
            "the Panda URDF comes from the 'example-robot-data' package, which is not installed"
            " — run: pip install example-robot-data"
        ) from exc
    for file in dist.files or ():
        if str(file).endswith("panda_description/urdf/panda.urdf"):
            return Path(str(dist.locate_file(file)))
    path = Path(str(dist.locate_file(_URDF_IN_WHEEL)))
    if not path.exists():
        raise RobotError(
            f"example-robot-data is installed but has no panda.urdf (looked for {path});"
            f" reinstall it or set {_ENV_OVERRIDE}"
        )
    return path


class Panda(Robot):
    """Franka Emika Panda: 7 torque-controlled joints, a two-finger parallel gripper."""

    name: ClassVar[str] = "panda"
    arm_joints: ClassVar[tuple[str, ...]] = tuple(f"panda_joint{i}" for i in range(1, 8))
    finger_joints: ClassVar[tuple[str, ...]] = ("panda_finger_joint1", "panda_finger_joint2")
    hand_body: ClassVar[str] = "panda_hand"
    root_body: ClassVar[str] = "panda_link0"
    finger_bodies: ClassVar[tuple[str, str]] = ("panda_leftfinger", "panda_rightfinger")
    hand_tcp_frame: ClassVar[str] = "panda_hand_tcp"
    """URDF frame of the bare hand's TCP, between the fingertips."""
    hand_tcp_site: ClassVar[str] = "tcp"
    """Site at `hand_tcp_frame` (the TCP unless a tool is mounted: see robots/tool.py)."""
    tcp_frame: ClassVar[str] = hand_tcp_frame
    home: ClassVar[tuple[float, ...]] = (0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785)
    gripper_open_m: ClassVar[float] = 0.04
    gripper_force_n: ClassVar[float] = 20.0
    gains: Gains = Gains(
        kp=np.array([600.0, 600.0, 600.0, 600.0, 250.0, 150.0, 50.0]),
        kd=np.array([50.0, 50.0, 50.0, 50.0, 20.0, 15.0, 5.0]),
    )
    datasheet: ClassVar[Datasheet | None] = Datasheet(
        position=(
            (-2.8973, 2.8973),
            (-1.7628, 1.7628),
            (-2.8973, 2.8973),
            (-3.0718, -0.0698),
            (-2.8973, 2.8973),
            (-0.0175, 3.7525),
            (-2.8973, 2.8973),
        ),
        velocity=(2.175, 2.175, 2.175, 2.175, 2.61, 2.61, 2.61),
        torque=(87.0, 87.0, 87.0, 87.0, 12.0, 12.0, 12.0),
        source="Franka Emika, Panda datasheet / FCI documentation, 'Limits for Panda' (joint "
        "space: q, dq, tau)",
    )
    payload_kg: ClassVar[float | None] = 3.0
    """Franka Emika Panda datasheet: payload 3 kg, the Franka Hand (0.73 kg) included."""
    acceleration_limits: ClassVar[tuple[float, ...]] = (15.0, 7.5, 10.0, 12.5, 15.0, 20.0, 20.0)
    """Franka's datasheet joint acceleration limits [rad/s^2]."""
    jerk_limits: ClassVar[tuple[float, ...]] = (7500.0, 3750.0, 5000.0, 6250.0, 7500.0, 1e4, 1e4)
    """Franka's datasheet joint jerk limits [rad/s^3]."""
    joint_friction_nm: ClassVar[tuple[float, ...] | None] = (
        0.55,
        0.87,
        0.64,
        1.28,
        0.84,
        0.30,
        0.56,
    )
    """Coulomb friction [Nm]: the saturation torque phi_1 of the friction model identified on
    a real Panda (Gaz, Cognetti, Oliva, Robuffo Giordano, De Luca, "Dynamic Identification of
    the Franka Emika Panda Robot With Retrieval of Feasible Parameters Using Penalty-Based
    Optimization", IEEE RA-L 4(4), 2019, table of friction parameters), rounded to 10 mNm."""
    joint_damping_nms: ClassVar[tuple[float, ...] | None] = (0.1,) * 7
    """Viscous friction [Nm s/rad]. Gaz et al.'s sigmoid model has no viscous term (their fit
    saturates at phi_1 within ~0.5 rad/s); 0.1 Nm s/rad adds a tenth of the smallest Coulomb
    friction at 1 rad/s, an assumption, not an identified value."""
    encoder_resolution_rad: ClassVar[float] = 2.0 * math.pi / 2**19
    """Joint position resolution [rad] (1.2e-5 rad): a 19-bit absolute encoder per turn on
    the link side (Franka does not publish the figure: an assumption of the common class of
    absolute encoder in torque-controlled arms)."""
    shoulder_height_m: ClassVar[float] = 0.333
    reach_m: ClassVar[float] = 0.855
    self_collision_bodies: ClassVar[tuple[str, ...]] = (
        *(f"panda_link{i}" for i in range(8)),
        "panda_hand",
    )
    """Links that get a self-collision proxy capsule (robots/self_collision.py)."""
    armature: ClassVar[float] = 0.1
    """Rotor inertia of each arm joint [kg m^2] (`joint_armature`): in the plant and in the
    controller's model alike."""

    def urdf_path(self) -> str:
        return str(panda_urdf_path())

    def build_spec(self) -> mujoco.MjSpec:
        mesh_dir = panda_urdf_path().parent.parent / "meshes" / "collision"
        return assemble(self, mesh_dir)

    def joint_armature(self, joint: str) -> float:
        del joint
        return self.armature
