"""Robot base: what the framework needs to know about an arm + gripper."""

from __future__ import annotations

import abc
import functools
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, ClassVar

import numpy as np

if TYPE_CHECKING:
    import mujoco
    import pinocchio as pin

__all__ = [
    "CARTESIAN_MASS",
    "CONTACT_SOLIMP",
    "CONTACT_TIMECONST_S",
    "Datasheet",
    "Gains",
    "ROBOT_CONAFFINITY",
    "ROBOT_CONTYPE",
    "Robot",
    "WORLD_CONAFFINITY",
    "WORLD_CONTYPE",
]

# Bit 1: robot geoms, bit 2: world geoms. Robot geoms do not collide with each other
# (the controller never folds the arm onto itself in these flows, and self-collision
# of the mesh links would dominate the step time: robots/self_collision.py has proxies).
ROBOT_CONTYPE, ROBOT_CONAFFINITY = 1, 2
WORLD_CONTYPE, WORLD_CONAFFINITY = 2, 3

CONTACT_TIMECONST_S = 0.004
"""Contact time constant (MuJoCo solref, damping ratio 1) of every rigid surface of a world:
links, fingers, tool, table, bins, floor, belt, obstacles, free objects (the tissue phantom has
a force law of its own). One value for all, so that no pair mixes a soft and a stiff side (the
table kept MuJoCo's 0.02 s: parcels dropped into a bin sank 8 mm into it). 4 ms is twice the
2 ms physics step, the stiffest MuJoCo integrates stably (it raises a smaller one to that
itself; at 2.5 ms, written directly, a dropped cube kept bouncing at 2-3 m/s)."""
CONTACT_SOLIMP = (0.5, 0.99, 0.001, 0.5, 2.0)
"""MuJoCo solimp of the same surfaces: the constraint's impedance rises from 0.5 at first touch
to 0.99 at 1 mm. Firm deep down, where an impact goes (a 20 cm drop, 2 m/s: 1.6 mm flat, 2.5
mm on a corner, after the step in which the contact is found; in that step a corner can cross
up to 4 mm, the 2 m/s times the 2 ms step, before anything pushes back) and where the 20 N grip
sits (0.7 mm; 1.1 mm with the rise over 2 mm), and giving at the surface: at MuJoCo's
0.9-0.95, a cube squeezed by the fingers against the table, both stiff, jammed with up to 49 N
at the wrist (pick_place, 6 seeds; 4-8 N with this). A cube at rest on the table: 0.07 mm."""


@dataclass(frozen=True)
class Gains:
    """Controller gains of an arm: its defaults, which a scenario may override
    (`robot.gains`).

    Attributes:
        kp: Joint stiffness in [Nm/rad] ([N/m] for a mobile base's linear joints). Shape
            (n_arm,).
        kd: Joint damping in [Nm s/rad] ([N s/m] likewise). Shape (n_arm,).
        cartesian_stiffness: Default Cartesian impedance stiffness, translational x, y, z in
            [N/m] then rotational in [Nm/rad]. Shape (6,).
        cartesian_damping: Its damping in [N s/m] and [Nm s/rad], shape (6,); None: critically
            damped for the nominal apparent mass (`CARTESIAN_MASS`).
        nullspace_stiffness: Posture stiffness in the nullspace of the Cartesian task [Nm/rad].
    """

    kp: np.ndarray
    kd: np.ndarray
    cartesian_stiffness: tuple[float, ...] = (500.0, 500.0, 500.0, 30.0, 30.0, 30.0)
    cartesian_damping: tuple[float, ...] | None = None
    nullspace_stiffness: float = 10.0

    def replaced(
        self,
        kp: Sequence[float] | None = None,
        kd: Sequence[float] | None = None,
        cartesian_stiffness: Sequence[float] | None = None,
        cartesian_damping: Sequence[float] | None = None,
        nullspace_stiffness: float | None = None,
    ) -> Gains:
        """These gains with the ones given (not None) replaced. A new Cartesian stiffness
        without a damping is critically damped (the old damping was for the old stiffness)."""
        if cartesian_damping is None and cartesian_stiffness is not None:
            damping: tuple[float, ...] | None = None
        else:
            damping = self.cartesian_damping if cartesian_damping is None else (
                tuple(cartesian_damping)
            )  # fmt: skip
        return Gains(
            kp=self.kp if kp is None else np.array(kp, dtype=float),
            kd=self.kd if kd is None else np.array(kd, dtype=float),
            cartesian_stiffness=self.cartesian_stiffness
            if cartesian_stiffness is None
            else tuple(cartesian_stiffness),
            cartesian_damping=damping,
            nullspace_stiffness=self.nullspace_stiffness
            if nullspace_stiffness is None
            else nullspace_stiffness,
        )


@dataclass(frozen=True)
class Datasheet:
    """An arm's joint limits as its maker publishes them: what the robot test holds the
    MuJoCo plant and the controller's model to (tests/test_robots.py).

    Attributes:
        position: Range of each arm joint [rad] ([m] for a base's linear joints), (lower,
            upper). Shape (n_arm, 2).
        velocity: Speed limit of each arm joint [rad/s] ([m/s]). Shape (n_arm,).
        torque: Torque limit of each arm joint [Nm] ([N]). Shape (n_arm,).
        source: Where the figures come from (document, edition).
    """

    position: tuple[tuple[float, float], ...]
    velocity: tuple[float, ...]
    torque: tuple[float, ...]
    source: str


CARTESIAN_MASS: tuple[float, ...] = (2.0, 2.0, 2.0, 0.1, 0.1, 0.1)
"""Nominal apparent mass [kg] x3 and inertia [kg m^2] x3 a critically damped default Cartesian
impedance is sized for."""


class Robot(abc.ABC):
    """An arm with a parallel gripper, described once for MuJoCo and for pinocchio.

    Subclasses set the names below and implement `build_spec` (the MuJoCo plant, robot only)
    and `urdf_path` (the same robot for the controller's pinocchio model).
    """

    name: ClassVar[str]
    arm_joints: ClassVar[tuple[str, ...]]
    finger_joints: ClassVar[tuple[str, ...]]
    tcp_site: ClassVar[str] = "tcp"
    wrist_site: ClassVar[str] = "wrist_ft"
    force_sensor: ClassVar[str] = "wrist_force"
    torque_sensor: ClassVar[str] = "wrist_torque"
    gripper_actuator: ClassVar[str] = "gripper"
    hand_body: ClassVar[str]
    root_body: ClassVar[str]
    """First body of the robot (its base link)."""
    finger_bodies: ClassVar[tuple[str, str]]
    tcp_frame: ClassVar[str]
    """Name of the TCP frame in the URDF (for pinocchio)."""
    home: ClassVar[tuple[float, ...]]
    """Arm joint angles of the home pose in [rad]."""
    gripper_open_m: ClassVar[float]
    """Per-finger opening when fully open in [m]."""
    gripper_force_n: ClassVar[float]
    """Grip force each finger can press with in [N]."""
    gripper_speed_mps: ClassVar[float] = 0.05
    """Speed of each finger when opening or closing [m/s]."""
    finger_m_per_unit: ClassVar[float] = 1.0
    """Each finger's opening [m] per unit of its joint's coordinate: 1 for slide fingers (their
    joints are the openings); for a revolute jaw closing on a fixed one (one finger joint, at
    0 where the two meet), half the jaw's radius [m/rad]: the angle times the radius is the gap
    at the jaw, and each side's opening is half the gap. `gripper_open_m`, `gripper_speed_mps`
    and every opening a skill commands are in metres either way."""
    grip_touch_speed_mps: ClassVar[float | None] = None
    """Closing speed of each finger over the last `grip_touch_from_m` before it meets the
    object it closes on [m/s] (`grasp` slows there); None: the whole way at the gripper's
    speed. For a jaw closing against a fixed one, which meets the object first and pushes
    it to the other (robots/so101)."""
    grip_touch_from_m: ClassVar[float] = 0.004
    """Each finger's opening beyond the object's half-width where that slow stretch starts [m]."""
    gripper_armature: ClassVar[float | None] = None
    """Rotor inertia of a revolute jaw's servo seen at its joint [kg m^2] (the plant's
    `armature` there); None: 10 g at the jaw, as a slide finger's, a motor that answers
    within a control tick. A geared servo's rotor makes the jaw a flywheel the motor takes
    `gripper_time_constant_s` to spin up (`HandDrive` allows for it)."""
    gains: Gains
    """The controller's gains: the robot's defaults (a class attribute), replaced on an
    instance by a scenario's `robot.gains` (`with_gains`)."""
    shoulder_height_m: ClassVar[float]
    """Height of the first pitch axis above the base [m]."""
    reach_m: ClassVar[float]
    """Farthest TCP distance from the shoulder [m]: beyond it a target is unreachable."""
    acceleration_limits: ClassVar[tuple[float, ...]]
    """Largest joint acceleration of each arm joint [rad/s^2] (datasheet)."""
    jerk_limits: ClassVar[tuple[float, ...]]
    """Largest joint jerk of each arm joint [rad/s^3] (datasheet)."""
    joint_friction_nm: ClassVar[tuple[float, ...] | None] = None
    """Coulomb friction of each arm joint [Nm] the plant gets when the scenario's
    `physics.realism` is on (None: the robot documents none)."""
    joint_damping_nms: ClassVar[tuple[float, ...] | None] = None
    """Viscous friction of each arm joint [Nm s/rad] under `physics.realism`."""
    encoder_resolution_rad: ClassVar[float] = 0.0
    """Resolution of the joint encoders [rad] under `physics.realism` (0: exact)."""
    base_joints: ClassVar[tuple[str, ...]] = ()
    """The planar joints of a mobile base (x [m], y [m], yaw [rad]), the first of
    `arm_joints`; empty for an arm fixed in the world."""
    base_body: ClassVar[str | None] = None
    """The chassis of a mobile base (cameras with `body: base` mount on it)."""
    payload_kg: ClassVar[float | None] = None
    """The arm's rated payload at its flange [kg], as its maker rates it: everything mounted
    there counts against it (the hand, a tool) and the object carried gets the rest (the
    grasp planning, `grasp_pose`, refuses a heavier object before anything is lifted). None:
    the robot documents none, and nothing is refused for its mass."""
    datasheet: ClassVar[Datasheet | None] = None
    """The maker's joint limits (None: the robot documents none; the robot test then has
    nothing to hold its model to and fails)."""

    @abc.abstractmethod
    def urdf_path(self) -> str:
        """Path to the URDF this robot is built from."""

    @abc.abstractmethod
    def build_spec(self) -> mujoco.MjSpec:
        """The robot alone as an MjSpec: actuators, sites, sensors and a `home` keyframe."""

    def with_gains(self, gains: Gains) -> Robot:
        """This robot, its controller to use `gains` (this instance only; the class keeps
        its defaults). Returns itself."""
        if len(gains.kp) != self.n_arm or len(gains.kd) != self.n_arm:
            raise ValueError(f"{self.name} has {self.n_arm} arm joints: kp and kd need as many")
        self.gains = gains
        return self

    @property
    def n_arm(self) -> int:
        return len(self.arm_joints)

    @property
    def mobile(self) -> bool:
        """The robot drives on a base of its own (its first joints are planar)."""
        return bool(self.base_joints)

    def shoulder(self, q: np.ndarray, base_pos: np.ndarray) -> np.ndarray:
        """World position of the arm's first pitch axis [m] at arm joint angles `q`.

        Args:
            q: Arm joint angles (`arm_joints` order). Shape (n_arm,).
            base_pos: Where the robot's root stands in the world [m]. Shape (3,).
        """
        del q
        return np.asarray(base_pos, float) + [0.0, 0.0, self.shoulder_height_m]

    def joint_velocity_limits(self) -> np.ndarray:
        """Speed limit of each arm joint [rad/s] (the URDF's `velocity`). Shape (n_arm,)."""
        return np.asarray(_pinocchio_model(self.urdf_path()).velocityLimit[: self.n_arm], float)

    @property
    def gripper_time_constant_s(self) -> float:
        """The gripper motor's mechanical time constant [s]: its rotor inertia over its
        back-EMF damping (robots/assembly.py `add_gripper`), the time a free jaw takes to
        reach 63 % of the speed a voltage step asks for. 0 without `gripper_armature`."""
        if self.gripper_armature is None:
            return 0.0
        gear = self.finger_m_per_unit
        damping = 2.0 * self.gripper_force_n * gear * gear / self.gripper_speed_mps
        return self.gripper_armature / damping

    def joint_armature(self, joint: str) -> float:
        """Rotor inertia of arm joint `joint` seen at the joint [kg m^2]: the motor's and
        gearbox's inertia times the gear ratio squared. The plant has it (MuJoCo's
        `armature`), and so does the controller's model (pinocchio's `armature`), as the
        same configured figure: a value of the drive's datasheet, not a reading of the
        plant. 0 unless the robot gives one."""
        del joint
        return 0.0

    def pinocchio_model(self) -> pin.Model:
        """The controller's own model of the robot (cached): loaded from the same URDF, with
        each arm joint's rotor inertia (`joint_armature`) in pinocchio's `armature`, which
        its mass matrix and inverse dynamics (CRBA, RNEA) add on the diagonal."""
        armature = tuple((j, self.joint_armature(j)) for j in self.arm_joints)
        return _pinocchio_model(self.urdf_path(), armature)


@functools.cache
def _pinocchio_model(urdf: str, armature: tuple[tuple[str, float], ...] = ()) -> pin.Model:
    """The URDF's model, each named joint's velocity coordinates given the rotor inertia
    paired with it [kg m^2]."""
    import pinocchio as pin

    model = pin.buildModelFromUrdf(urdf)
    for name, inertia in armature:
        joint = model.getJointId(name)
        start = model.idx_vs[joint]
        model.armature[start : start + model.nvs[joint]] = inertia
    return model
