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
from .scenario import Scenario

__all__ = ["ObjectHandle", "World", "as_index", "robot_only_model"]


@dataclass(frozen=True)
class ObjectHandle:
    """Indices of one free object in the compiled model."""

    name: str
    body_id: int
    qpos_adr: int
    qvel_adr: int
    geom_id: int
    half_size: np.ndarray


@functools.cache
def robot_only_model(robot_name: str) -> mujoco.MjModel:
    """The robot alone, compiled once per process: the kinematic model IK works on."""
    return get_robot(robot_name).build_spec().compile()


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
        self.wrist_bias_world = float(m.body_subtreemass[self.hand_body]) * gravity
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
        self.home = np.array(robot.home, dtype=float)
        self.reset()

    @classmethod
    def build(cls, scenario: Scenario, seed: int) -> World:
        """Assemble robot + table + objects + markers with MjSpec and compile them."""
        robot = get_robot(scenario.robot.name)
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
        return cls(scenario, seed, robot, spec.compile())

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
