"""The Franka Panda plant, assembled with MjSpec from example-robot-data's URDF."""

from __future__ import annotations

import functools
import importlib.metadata
import math
import os
from pathlib import Path
from typing import TYPE_CHECKING, ClassVar

import numpy as np

from ..base import CONTACT_SOLIMP, CONTACT_TIMECONST_S, Datasheet, Gains, Robot
from ..exceptions import RobotError
from ..self_collision import add_self_collision_proxies

if TYPE_CHECKING:
    import mujoco

__all__ = ["Panda", "panda_urdf_path"]

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


# Bit 1: robot geoms, bit 2: world geoms. Robot geoms do not collide with each other
# (the controller never folds the arm onto itself in these flows, and self-collision
# of the mesh links would dominate the step time).
ROBOT_CONTYPE, ROBOT_CONAFFINITY = 1, 2
WORLD_CONTYPE, WORLD_CONAFFINITY = 2, 3


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
        import mujoco

        mesh_dir = panda_urdf_path().parent.parent / "meshes" / "collision"
        spec = mujoco.MjSpec.from_string(Path(self.urdf_path()).read_text())
        spec.modelname = self.name
        # The URDF parser already left out the <visual> meshes (MuJoCo cannot read the DAE
        # files); discarding visual geoms at compile time would also drop the scene's
        # collision-free geoms (place pads, zones), so keep them.
        spec.compiler.discardvisual = False
        spec.compiler.fusestatic = False  # panda_hand stays a body: the wrist sensor needs it
        spec.compiler.balanceinertia = True
        for mesh in spec.meshes:
            mesh.file = str(mesh_dir / Path(mesh.file).name)
        for geom in spec.geoms:
            geom.contype, geom.conaffinity = ROBOT_CONTYPE, ROBOT_CONAFFINITY
            geom.solref = [CONTACT_TIMECONST_S, 1.0]
            geom.solimp = list(CONTACT_SOLIMP)
        for joint in spec.joints:
            joint.damping = [0.0, 0.0, 0.0]
            joint.frictionloss = 0.0
        for jname in self.arm_joints:
            joint = spec.joint(jname)
            joint.armature = self.joint_armature(jname)
        self._add_actuators(spec)  # arm motors first: ctrl[:n_arm] are the arm torques
        self._add_gripper(spec)
        self._add_sites_and_sensors(spec)
        add_self_collision_proxies(spec, self.name, self.self_collision_bodies, self.home)
        return spec

    def joint_armature(self, joint: str) -> float:
        del joint
        return self.armature

    def _add_actuators(self, spec: mujoco.MjSpec) -> None:
        import mujoco

        for jname in self.arm_joints:
            joint = spec.joint(jname)
            effort = _urdf_efforts(self.urdf_path())[jname]
            act = spec.add_actuator(name=jname.replace("joint", "motor"), target=jname)
            act.trntype = mujoco.mjtTrn.mjTRN_JOINT
            act.ctrllimited = True
            act.ctrlrange = [-effort, effort]
            act.forcelimited = True
            act.forcerange = [-effort, effort]
            del joint

    def _add_gripper(self, spec: mujoco.MjSpec) -> None:
        # The hand's motor, not a position servo: a DC motor through its gearbox pushes each
        # finger with F (u - v / v_max), u in [-1, 1] its voltage (ctrl), v the finger's
        # speed. Stalled (squeezing an object) it pushes with F, the hand's grip force; free,
        # it runs at v_max at most, whatever it is told: the hand's speed limit lives in the
        # plant, not in the software that drives it (engine/context.py, `advance_gripper`).
        import mujoco

        # The back-EMF term is the fingers' viscous damping F / v_max: MuJoCo's implicit
        # integrators take joint damping implicitly, an actuator's velocity bias they did not
        # (the fingers rang between 0.048 and 0.052 m/s at full voltage).
        j1, j2 = self.finger_joints
        for jname in self.finger_joints:
            joint = spec.joint(jname)
            joint.armature = 0.01
            joint.damping = [self.gripper_force_n / self.gripper_speed_mps, 0.0, 0.0]
            # the end stops as firm as a contact: at MuJoCo's default (0.02 s, 0.9-0.95) the
            # motor drove a light finger 15 mm past its 40 mm stroke (tests/test_robots.py)
            joint.solref_limit = [CONTACT_TIMECONST_S, 1.0]
            joint.solimp_limit = list(CONTACT_SOLIMP)
        for bname in self.finger_bodies:
            for geom in spec.body(bname).geoms:
                geom.friction = [1.5, 0.01, 0.001]
                geom.condim = 4
                geom.solref = [CONTACT_TIMECONST_S, 1.0]
                geom.solimp = list(CONTACT_SOLIMP)
        # one motor drives both fingers through a rack and pinion: as stiff a coupling as
        # the step allows. The URDF's <mimic> comes in as a second, softer equality on the
        # same two joints (MuJoCo's default time constant, 0.02 s): one constraint row more
        # for every step's solver, nothing the one below does not hold, so it goes.
        mimic = mujoco.mjtEq.mjEQ_JOINT
        for imported in list(spec.equalities):
            if imported.type == mimic and {imported.name1, imported.name2} == {j1, j2}:
                spec.delete(imported)
        eq = spec.add_equality(name="finger_mimic", type=mimic)
        eq.name1, eq.name2 = j1, j2
        eq.data[0:5] = [0, 1, 0, 0, 0]
        eq.solref = [CONTACT_TIMECONST_S, 1.0]
        tendon = spec.add_tendon(name="finger_split")
        tendon.wrap_joint(j1, 0.5)
        tendon.wrap_joint(j2, 0.5)
        stall = 2.0 * self.gripper_force_n  # the tendon's force: each finger gets half
        act = spec.add_actuator(name=self.gripper_actuator, target="finger_split")
        act.trntype = mujoco.mjtTrn.mjTRN_TENDON
        act.gaintype = mujoco.mjtGain.mjGAIN_FIXED
        act.biastype = mujoco.mjtBias.mjBIAS_NONE
        act.gainprm[0] = stall
        act.ctrllimited = True
        act.ctrlrange = [-1.0, 1.0]
        act.forcelimited = True
        act.forcerange = [-stall, stall]

    def _add_sites_and_sensors(self, spec: mujoco.MjSpec) -> None:
        import mujoco

        hand_tcp = spec.body(self.hand_tcp_frame)
        hand_tcp.add_site(name=self.hand_tcp_site, size=[0.005, 0.005, 0.005])
        spec.body(self.hand_body).add_site(name=self.wrist_site, size=[0.005, 0.005, 0.005])
        force = spec.add_sensor(name=self.force_sensor, type=mujoco.mjtSensor.mjSENS_FORCE)
        force.objtype, force.objname = mujoco.mjtObj.mjOBJ_SITE, self.wrist_site
        torque = spec.add_sensor(name=self.torque_sensor, type=mujoco.mjtSensor.mjSENS_TORQUE)
        torque.objtype, torque.objname = mujoco.mjtObj.mjOBJ_SITE, self.wrist_site
        key = spec.add_key(name="home")
        key.qpos = [*self.home, self.gripper_open_m, self.gripper_open_m]
        key.ctrl = [0.0] * (self.n_arm + 1)


@functools.cache
def _urdf_efforts(urdf: str) -> dict[str, float]:
    """Effort limit of each joint of the URDF at `urdf` [Nm or N]."""
    import xml.etree.ElementTree as ET

    root = ET.parse(urdf).getroot()
    out: dict[str, float] = {}
    for joint in root.iter("joint"):
        limit = joint.find("limit")
        if limit is not None and "effort" in limit.attrib:
            out[joint.attrib["name"]] = float(limit.attrib["effort"])
    return out
