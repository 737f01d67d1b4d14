"""World: the scenario's robot and scene compiled into one MuJoCo model (the body)."""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import mujoco
import numpy as np

from .pose import quat_from_yaw
from .robots import Robot, get_robot
from .robots.panda.model import WORLD_CONAFFINITY, WORLD_CONTYPE
from .robots.tool import TISSUE_CONAFFINITY, TISSUE_CONTYPE, Tool, mount_tool
from .scenario import Scenario, ToolSpec

__all__ = ["ObjectHandle", "PhantomHandle", "World", "as_index", "robot_only_model"]


@dataclass(frozen=True)
class ObjectHandle:
    """Indices of one free object in the compiled model."""

    name: str
    body_id: int
    qpos_adr: int
    qvel_adr: int
    geom_id: int
    half_size: np.ndarray


@dataclass(frozen=True)
class PhantomHandle:
    """The tissue phantom of one episode (ground truth: perception skills add noise).

    Attributes:
        name: Its name in the scenario.
        size: Full edge lengths [m]. Shape (3,).
        surface_pos: Centre of its top surface in the world [m]. Shape (3,).
        yaw: Its heading about world z [rad].
        stiffness_n_per_m: The true stiffness of this episode [N/m].
    """

    name: str
    size: np.ndarray
    surface_pos: np.ndarray
    yaw: float
    stiffness_n_per_m: float


def robot_only_model(robot: str | Robot) -> mujoco.MjModel:
    """The robot alone (with its tool, if it carries one), compiled once per process: the
    kinematic model IK works on."""
    if isinstance(robot, str):
        return _robot_only_model(robot, None)
    return _robot_only_model(robot.name, getattr(robot, "tool", None))


@functools.cache
def _robot_only_model(robot_name: str, tool: Tool | None) -> mujoco.MjModel:
    robot = get_robot(robot_name)
    return (mount_tool(robot, tool) if tool is not None else robot).build_spec().compile()


class World:
    """The compiled plant of one episode and the indices the runtime needs.

    Build with `World.build(scenario, seed)`: the seed fixes the randomized object poses.
    """

    def __init__(self, scenario: Scenario, seed: int, robot: Robot, model: mujoco.MjModel) -> None:
        self.scenario = scenario
        self.seed = seed
        self.robot = robot
        self.model = model
        self.data = mujoco.MjData(model)
        m = model
        self.arm_qpos = np.array([m.jnt_qposadr[m.joint(j).id] for j in robot.arm_joints])
        self.arm_dof = np.array([m.jnt_dofadr[m.joint(j).id] for j in robot.arm_joints])
        robot_joints = (*robot.arm_joints, *robot.finger_joints)
        self.robot_qpos = np.array([m.jnt_qposadr[m.joint(j).id] for j in robot_joints])
        self.robot_dof = np.array([m.jnt_dofadr[m.joint(j).id] for j in robot_joints])
        self.finger_qpos = self.robot_qpos[robot.n_arm :]
        self.arm_qpos_index = as_index(self.arm_qpos)
        """`arm_qpos` as a slice when contiguous: cheaper on the per-step path."""
        self.arm_act = np.array(
            [m.actuator(j.replace("joint", "motor")).id for j in robot.arm_joints]
        )
        self.gripper_act = m.actuator(robot.gripper_actuator).id
        self.tcp_site = m.site(robot.tcp_site).id
        self.wrist_site = m.site(robot.wrist_site).id
        self.force_adr = m.sensor_adr[m.sensor(robot.force_sensor).id]
        self.torque_adr = m.sensor_adr[m.sensor(robot.torque_sensor).id]
        self.hand_body = m.body(robot.hand_body).id
        self.finger_body_ids = tuple(m.body(b).id for b in robot.finger_bodies)
        self.finger_geoms = frozenset(
            g for g in range(m.ngeom) if m.geom_bodyid[g] in self.finger_body_ids
        )
        robot_root = m.body(robot.root_body).id
        self.robot_geoms = frozenset(
            g for g in range(m.ngeom) if _is_descendant(m, int(m.geom_bodyid[g]), robot_root)
        )
        gravity = -m.opt.gravity
        tool: Tool | None = getattr(robot, "tool", None)
        # the sensor's own calibration knows the hand, not a tool mounted on it
        hand_mass = float(m.body_subtreemass[self.hand_body]) - (tool.mass_kg if tool else 0.0)
        self.wrist_bias_world = hand_mass * gravity
        """Force [N] the arm exerts on the hand at rest (its weight), removed from readings."""
        self.objects: dict[str, ObjectHandle] = {}
        for spec in scenario.scene.objects:
            body = m.body(spec.name)
            jnt = m.body_jntadr[body.id]
            self.objects[spec.name] = ObjectHandle(
                name=spec.name,
                body_id=body.id,
                qpos_adr=int(m.jnt_qposadr[jnt]),
                qvel_adr=int(m.jnt_dofadr[jnt]),
                geom_id=int(m.body_geomadr[body.id]),
                half_size=np.asarray(spec.size) / 2.0,
            )
        table = scenario.scene.table
        self.markers: dict[str, np.ndarray] = {
            mk.name: np.array([*mk.xy, table.height]) for mk in scenario.scene.markers
        }
        self.table_height = table.height
        self.phantom: PhantomHandle | None = _phantom_handle(scenario, seed)
        self.zones: dict[str, int] = {z.name: m.geom(z.name).id for z in scenario.scene.zones}
        """No-go zone name -> its (collision-free) box geom."""
        self.home = np.array(robot.home, dtype=float)
        self.reset()

    @classmethod
    def build(cls, scenario: Scenario, seed: int) -> World:
        """Assemble robot + table + objects + markers with MjSpec and compile them."""
        robot = get_robot(scenario.robot.name)
        if scenario.tool is not None:
            robot = mount_tool(robot, _tool(scenario.tool))
        spec = robot.build_spec()
        for key in list(spec.keys):
            spec.delete(key)  # the world sets its initial state itself
        spec.modelname = f"{scenario.name}"
        spec.option.timestep = scenario.physics.timestep_s
        spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
        spec.option.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
        spec.option.impratio = 10.0
        spec.body(robot.root_body).pos = scenario.robot.base_pos
        _add_scene(spec, scenario, seed)
        _add_phantom_scene(spec, scenario, seed)
        model = spec.compile()
        _set_tissue_stiffness(model, scenario, seed, robot)
        return cls(scenario, seed, robot, model)

    def reset(self) -> None:
        """Robot at home with the gripper open, objects at their seeded poses, at rest."""
        m, d = self.model, self.data
        mujoco.mj_resetData(m, d)
        d.qpos[self.arm_qpos] = self.home
        d.qpos[self.finger_qpos] = self.robot.gripper_open_m
        d.ctrl[self.gripper_act] = self.robot.gripper_open_m
        for name, pos, quat in _object_poses(self.scenario, self.seed):
            h = self.objects[name]
            d.qpos[h.qpos_adr : h.qpos_adr + 3] = pos
            d.qpos[h.qpos_adr + 3 : h.qpos_adr + 7] = quat
        mujoco.mj_forward(m, d)
        # Sensors at t = 0 read the arm held still, as it is from the first step on (with zero
        # torques they would read it falling); the runner sets the torques before stepping.
        d.ctrl[self.arm_act] = d.qfrc_bias[self.arm_dof]
        mujoco.mj_forward(m, d)


def as_index(idx: np.ndarray) -> slice | np.ndarray:
    """A slice when the indices are contiguous (cheaper on the hot path)."""
    if len(idx) and np.all(np.diff(idx) == 1):
        return slice(int(idx[0]), int(idx[-1]) + 1)
    return idx


def _is_descendant(m: mujoco.MjModel, body: int, root: int) -> bool:
    while body > 0:
        if body == root:
            return True
        body = int(m.body_parentid[body])
    return root == 0


def _object_poses(scenario: Scenario, seed: int) -> list[tuple[str, np.ndarray, np.ndarray]]:
    """Per-seed poses of the free objects: nominal + uniform offsets from the seed."""
    rng = np.random.default_rng([seed, 0x5CE4E])
    out = []
    top = scenario.scene.table.height
    for obj in scenario.scene.objects:
        r = obj.randomize
        dx = rng.uniform(r.x[0], r.x[1])
        dy = rng.uniform(r.y[0], r.y[1])
        dyaw = rng.uniform(r.yaw_deg[0], r.yaw_deg[1])
        pos = np.array([obj.xy[0] + dx, obj.xy[1] + dy, top + obj.size[2] / 2.0])
        quat = quat_from_yaw(math.radians(obj.yaw_deg + dyaw))
        out.append((obj.name, pos, quat))
    return out


def _add_scene(spec: mujoco.MjSpec, scenario: Scenario, seed: int) -> None:
    scene = scenario.scene
    wb = spec.worldbody
    floor = wb.add_geom(name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[2.0, 2.0, 0.05])
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
    poses = {name: (pos, quat) for name, pos, quat in _object_poses(scenario, seed)}
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


# -- tool, phantom, zones, obstacles ----------------------------------------------------------

TISSUE_IMPEDANCE = 0.1
"""MuJoCo constraint impedance d of tissue contacts (solimp dmin = dmax). A soft constraint
resists acceleration like an added mass of d / ((1 - d) A), A the inverse inertia at the
contact: at MuJoCo's default d ~ 0.9 that is ~60 kg at the Panda's tool tip and a phantom
pressed with a few newtons rings at ~1 Hz; at 0.1 it is ~0.7 kg."""


ZONE_CONTYPE = 16
"""Collision bit of no-go zones, set in no other geom's conaffinity: zones collide with
nothing; the no_go_zone guard measures distances to them itself."""


def _tool(spec: ToolSpec) -> Tool:
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


def phantom_state(scenario: Scenario, seed: int) -> tuple[np.ndarray, float, float]:
    """Per-seed surface centre [m] (shape (3,)), yaw [rad] and true stiffness [N/m] of the
    phantom: nominal + uniform offsets from the seed (its own random stream)."""
    ph = scenario.scene.phantom
    assert ph is not None
    rng = np.random.default_rng([seed, 0xFA27])
    r = ph.randomize
    dx = rng.uniform(r.x[0], r.x[1])
    dy = rng.uniform(r.y[0], r.y[1])
    scale = rng.uniform(r.stiffness_scale[0], r.stiffness_scale[1])
    top = scenario.scene.table.height + ph.size[2]
    pos = np.array([ph.xy[0] + dx, ph.xy[1] + dy, top])
    return pos, math.radians(ph.yaw_deg), float(ph.stiffness_n_per_m * scale)


def _phantom_handle(scenario: Scenario, seed: int) -> PhantomHandle | None:
    ph = scenario.scene.phantom
    if ph is None:
        return None
    pos, yaw, stiffness = phantom_state(scenario, seed)
    return PhantomHandle(
        name=ph.name,
        size=np.asarray(ph.size, float),
        surface_pos=pos,
        yaw=yaw,
        stiffness_n_per_m=stiffness,
    )


def _add_phantom_scene(spec: mujoco.MjSpec, scenario: Scenario, seed: int) -> None:
    """The phantom (a fixed compliant box), the zones (drawn, no collision) and obstacles."""
    scene = scenario.scene
    ph = scene.phantom
    body = spec.worldbody
    if ph is not None:
        surface, yaw, _ = phantom_state(scenario, seed)
        centre = surface - [0.0, 0.0, ph.size[2] / 2.0]
        body = spec.worldbody.add_body(
            name=ph.name, pos=centre.tolist(), quat=quat_from_yaw(yaw).tolist()
        )
        g = body.add_geom(
            name=ph.name, type=mujoco.mjtGeom.mjGEOM_BOX, size=[v / 2 for v in ph.size]
        )
        g.rgba = ph.rgba
        g.friction = [ph.friction, 0.005, 0.0001]
        g.contype, g.conaffinity = TISSUE_CONTYPE, TISSUE_CONAFFINITY
        g.priority = 1  # its solref, solimp and friction win over the other geom's
        g.solimp = [TISSUE_IMPEDANCE, TISSUE_IMPEDANCE, 0.001, 0.5, 2.0]
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


def _set_tissue_stiffness(
    model: mujoco.MjModel, scenario: Scenario, seed: int, robot: Robot
) -> None:
    """Direct solref (-stiffness, -damping) of the phantom for its true stiffness [N/m].

    At rest MuJoCo's soft contact satisfies R f = k d r with R = (1 - d) / d * A0 and
    k = S / d^2 for solref[0] = -S (dmin = dmax = d), A0 the contact's approximate inverse
    inertia (`body_invweight0` of the two bodies; the phantom is fixed). So f = S r / ((1 - d)
    A0): S = stiffness (1 - d) A0, exact for contacts of the TCP's body (the tool tip).
    """
    ph = scenario.scene.phantom
    if ph is None:
        return
    _, _, stiffness = phantom_state(scenario, seed)
    tcp_body = int(model.site_bodyid[model.site(robot.tcp_site).id])
    inv_weight = float(model.body_invweight0[tcp_body, 0])
    scale = (1.0 - TISSUE_IMPEDANCE) * inv_weight
    model.geom_solref[model.geom(ph.name).id] = [
        -stiffness * scale,
        -ph.damping_n_s_per_m * scale,
    ]
