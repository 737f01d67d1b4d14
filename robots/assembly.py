"""A robot's MuJoCo plant assembled from its URDF with MjSpec: what every arm here shares.

`assemble(robot, mesh_dir)` reads `robot.urdf_path()` (the file the controller's pinocchio model
is built from too) and adds, in this order, the arm's torque motors (their limits the URDF's
effort limits), the gripper's motor, the wrist force/torque sensor, the TCP site, a `home`
keyframe and the self-collision proxies. The gripper is either two coupled slide fingers (one
motor through a rack and pinion: the Panda's hand, a Robotiq-class parallel gripper) or one
revolute jaw against a fixed one (a hobby arm's servo jaw, `Robot.jaw`).
"""

from __future__ import annotations

import functools
from pathlib import Path
from typing import TYPE_CHECKING

from .base import CONTACT_SOLIMP, CONTACT_TIMECONST_S, ROBOT_CONAFFINITY, ROBOT_CONTYPE, Robot
from .self_collision import add_self_collision_proxies

if TYPE_CHECKING:
    import mujoco

__all__ = ["assemble", "urdf_efforts", "write_urdf"]


def assemble(robot: Robot, mesh_dir: Path) -> mujoco.MjSpec:
    """The robot alone as an MjSpec, from its URDF, its collision meshes in `mesh_dir`."""
    import mujoco

    spec = mujoco.MjSpec.from_string(Path(robot.urdf_path()).read_text())
    spec.modelname = robot.name
    # The URDF parser already left out the <visual> meshes (MuJoCo cannot read the DAE
    # files); discarding visual geoms at compile time would also drop the scene's
    # collision-free geoms (place pads, zones), so keep them.
    spec.compiler.discardvisual = False
    spec.compiler.fusestatic = False  # the hand stays a body: the wrist sensor needs it
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
    for jname in robot.arm_joints:
        joint = spec.joint(jname)
        joint.armature = robot.joint_armature(jname)
    add_arm_motors(robot, spec)  # arm motors first: ctrl[:n_arm] are the arm torques
    add_gripper(robot, spec)
    add_sites_and_sensors(robot, spec)
    add_self_collision_proxies(
        spec, robot.name, getattr(robot, "self_collision_bodies", ()), robot.home
    )
    return spec


def add_arm_motors(robot: Robot, spec: mujoco.MjSpec) -> None:
    """One torque motor per arm joint, limited to the URDF's effort limit (named after the
    joint, `joint` -> `motor`)."""
    import mujoco

    efforts = urdf_efforts(robot.urdf_path())
    for jname in robot.arm_joints:
        effort = efforts[jname]
        act = spec.add_actuator(name=jname.replace("joint", "motor"), target=jname)
        act.trntype = mujoco.mjtTrn.mjTRN_JOINT
        act.ctrllimited = True
        act.ctrlrange = [-effort, effort]
        act.forcelimited = True
        act.forcerange = [-effort, effort]


def add_gripper(robot: Robot, spec: mujoco.MjSpec) -> None:
    """The hand's motor, not a position servo: a DC motor through its gearbox pushes each
    finger with F (u - v / v_max), u in [-1, 1] its voltage (ctrl), v the finger's speed.
    Stalled (squeezing an object) it pushes with F, the hand's grip force; free, it runs at
    v_max at most, whatever it is told: the hand's speed limit lives in the plant, not in the
    software that drives it (robots/hand.py, `HandDrive.advance`).

    The back-EMF term is the fingers' viscous damping F / v_max: MuJoCo's implicit
    integrators take joint damping implicitly, an actuator's velocity bias they did not (the
    fingers rang between 0.048 and 0.052 m/s at full voltage).

    Two finger joints: one motor drives both through a rack and pinion (a tendon splits its
    force, an equality couples them). One: a revolute jaw whose coordinate is written in
    metres of opening at its tip (`Robot.jaw`): the same F and v_max there.
    """
    import mujoco

    force, speed = robot.gripper_force_n, robot.gripper_speed_mps
    jaw = len(robot.finger_joints) == 1
    gear = robot.finger_m_per_unit  # [m] of each side's opening per unit of the joint
    for jname in robot.finger_joints:
        joint = spec.joint(jname)
        if jaw:  # the motor's 2F at `gear`: F at the jaw; free, each side at v_max
            rotor = robot.gripper_armature  # the servo's rotor; else 10 g at the jaw
            joint.armature = 0.01 * gear * gear if rotor is None else rotor
            joint.damping = [2.0 * force * gear * gear / speed, 0.0, 0.0]
        else:
            joint.armature = 0.01
            joint.damping = [force / speed, 0.0, 0.0]
        # the end stops as firm as a contact: at MuJoCo's default (0.02 s, 0.9-0.95) the
        # motor drove a light finger 15 mm past its 40 mm stroke (tests/test_robots.py)
        joint.solref_limit = [CONTACT_TIMECONST_S, 1.0]
        joint.solimp_limit = list(CONTACT_SOLIMP)
    for bname in robot.finger_bodies:
        for geom in spec.body(bname).geoms:
            geom.friction = [1.5, 0.01, 0.001]
            geom.condim = 4
            geom.solref = [CONTACT_TIMECONST_S, 1.0]
            geom.solimp = list(CONTACT_SOLIMP)
    if jaw:  # its length: each side's opening [m]; its force: twice the jaw's [N]
        act = spec.add_actuator(name=robot.gripper_actuator, target=robot.finger_joints[0])
        act.trntype = mujoco.mjtTrn.mjTRN_JOINT
        act.gear[0] = gear
        stall = 2.0 * force
    else:
        j1, j2 = robot.finger_joints
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
        stall = 2.0 * force  # the tendon's force: each finger gets half
        act = spec.add_actuator(name=robot.gripper_actuator, target="finger_split")
        act.trntype = mujoco.mjtTrn.mjTRN_TENDON
    act.gaintype = mujoco.mjtGain.mjGAIN_FIXED
    act.biastype = mujoco.mjtBias.mjBIAS_NONE
    act.gainprm[0] = stall
    act.ctrllimited = True
    act.ctrlrange = [-1.0, 1.0]
    act.forcelimited = True
    act.forcerange = [-stall, stall]


def add_sites_and_sensors(robot: Robot, spec: mujoco.MjSpec) -> None:
    """The TCP site on the URDF's TCP frame, the wrist force/torque sensor on the hand, and
    the `home` keyframe (the gripper open)."""
    import mujoco

    tcp_body = getattr(robot, "hand_tcp_frame", robot.tcp_frame)
    tcp_site = getattr(robot, "hand_tcp_site", robot.tcp_site)
    spec.body(tcp_body).add_site(name=tcp_site, size=[0.005, 0.005, 0.005])
    spec.body(robot.hand_body).add_site(name=robot.wrist_site, size=[0.005, 0.005, 0.005])
    force = spec.add_sensor(name=robot.force_sensor, type=mujoco.mjtSensor.mjSENS_FORCE)
    force.objtype, force.objname = mujoco.mjtObj.mjOBJ_SITE, robot.wrist_site
    torque = spec.add_sensor(name=robot.torque_sensor, type=mujoco.mjtSensor.mjSENS_TORQUE)
    torque.objtype, torque.objname = mujoco.mjtObj.mjOBJ_SITE, robot.wrist_site
    key = spec.add_key(name="home")
    opening = robot.gripper_open_m / robot.finger_m_per_unit
    key.qpos = [*robot.home, *([opening] * len(robot.finger_joints))]
    key.ctrl = [0.0] * (robot.n_arm + 1)


@functools.cache
def urdf_efforts(urdf: str) -> dict[str, float]:
    """Effort limit of each joint of the URDF at `urdf` [Nm or N]."""
    import xml.etree.ElementTree as ET

    root = ET.parse(urdf).getroot()
    out: dict[str, float] = {}
    for joint in root.iter("joint"):
        limit = joint.find("limit")
        if limit is not None and "effort" in limit.attrib:
            out[joint.attrib["name"]] = float(limit.attrib["effort"])
    return out


def write_urdf(robot: str, text: str) -> Path:
    """`text` (a URDF the robot's class composed) as a file MuJoCo and pinocchio can read: in
    the temporary folder, named by its content, so a worker reuses the file another wrote."""
    import hashlib  # here: reading the robot's declaration (validate) needs no digest
    import os
    import tempfile

    digest = hashlib.sha256(text.encode()).hexdigest()[:16]
    path = Path(tempfile.gettempdir()) / f"orchestrator-{robot}-{digest}.urdf"
    if not path.exists():
        tmp = path.with_suffix(f".{os.getpid()}.tmp")
        tmp.write_text(text)
        os.replace(tmp, path)  # atomic: parallel workers never read half a file
    return path
