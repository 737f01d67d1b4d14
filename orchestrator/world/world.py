"""World: the scenario's robot and scene compiled into one MuJoCo model (the body)."""

from __future__ import annotations

import functools
from collections.abc import Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import mujoco
import numpy as np

from ..robots import Robot, get_robot
from ..robots.tool import Tool, mount_tool
from .cameras import add_cameras, randomize_appearance
from .contacts import ContactSensor, add_contact_sensors, bind_contact_sensors
from .conveyor import ConveyorBelt, add_conveyor
from .faults import FaultEffects, add_fault_obstacles
from .indexing import as_index
from .phantom import (
    PhantomHandle,
    add_phantom_scene,
    phantom_handle,
    set_tissue_stiffness,
    tool_from_spec,
)
from .randomization import object_poses
from .realism import apply_joint_friction
from .scene import add_scene, harden_contacts
from .step_clock import StepClock

if TYPE_CHECKING:
    from ..language.scenario import Scenario

__all__ = ["BRAKE_SOLIMP", "SLEEP", "ObjectHandle", "World", "as_index", "robot_only_model"]

SLEEP = int(mujoco.mjtEnableBit.mjENBL_SLEEP)
"""MuJoCo's enable flag of island sleeping, set on every world."""

BRAKE_SOLIMP = (0.9999, 0.9999)
"""Impedance (`solimp` dmin, dmax) of an engaged holding brake's friction: nearly rigid, so a
braked joint holds its load instead of creeping (see `World.engage_brake`)."""
BRAKE_TIMECONST_S = 0.004
"""Time constant of an engaged brake's friction [s] (`solref`; MuJoCo's default 0.02 let a
joint still turning at 0.2 rad/s when its brake engaged run on for ~40 ms)."""


@dataclass(frozen=True)
class ObjectHandle:
    """Indices of one free object in the compiled model."""

    name: str
    """The object's name in the scenario."""
    body_id: int
    """Its body in `ctx.model` (`ctx.data.xpos[body_id]`)."""
    qpos_adr: int
    """Where its free joint starts in `ctx.data.qpos`: position [m] (3), then quaternion (4)."""
    qvel_adr: int
    """Where its free joint starts in `ctx.data.qvel`: linear [m/s] (3), angular [rad/s] (3)."""
    geom_id: int
    """Its box geom in `ctx.model` (contacts name it)."""
    half_size: np.ndarray
    """Half its edge lengths along its own axes [m], shape (3,)."""


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

    def __init__(
        self,
        scenario: Scenario,
        seed: int,
        robot: Robot,
        model: mujoco.MjModel,
        contact_sensors: list[ContactSensor] | None = None,
    ) -> None:
        self.scenario = scenario
        self.seed = seed
        self.parcel_classes: dict[str, str] = {}
        """Parcel name -> its true class, for the parcels of `scene.parcels` (a conveyor's
        bodies: the class of the parcel each carries now)."""
        self.conveyor: ConveyorBelt | None = None
        """The belt of a conveyor cell (`scene.conveyor`), attached by `build`."""
        self.robot = robot
        self.model = model
        self.data = mujoco.MjData(model)
        m = model
        self.arm_qpos = np.array([m.jnt_qposadr[m.joint(j).id] for j in robot.arm_joints])
        self.arm_dof = np.array([m.jnt_dofadr[m.joint(j).id] for j in robot.arm_joints])
        self._friction0 = m.dof_frictionloss[self.arm_dof].copy()
        """Each arm joint's own friction loss, restored when its holding brake is released."""
        self._solimp0 = m.dof_solimp[self.arm_dof].copy()
        self._solref0 = m.dof_solref[self.arm_dof].copy()
        """Each arm joint's friction impedance and time constant, restored when its holding
        brake is released."""
        self.braked: set[int] = set()
        """Arm joints (0-based) whose holding brake is engaged."""
        robot_joints = (*robot.arm_joints, *robot.finger_joints)
        self.robot_qpos = np.array([m.jnt_qposadr[m.joint(j).id] for j in robot_joints])
        self.robot_dof = np.array([m.jnt_dofadr[m.joint(j).id] for j in robot_joints])
        self.finger_qpos = self.robot_qpos[robot.n_arm :]
        self.arm_qpos_index = as_index(self.arm_qpos)
        """`arm_qpos` as a slice when contiguous: cheaper on the per-step path."""
        self.arm_act = np.array(
            [m.actuator(j.replace("joint", "motor")).id for j in robot.arm_joints]
        )
        self.arm_act_index = as_index(self.arm_act)
        """`arm_act` as a slice when contiguous."""
        self.arm_effort_limit = m.actuator_ctrlrange[self.arm_act, 1].copy()
        """Torque limit of each arm joint's motor [Nm]. Shape (n_arm,)."""
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
        self.wrist_weight_world = float(m.body_subtreemass[self.hand_body]) * gravity
        """True weight of everything on the wrist sensor (hand, fingers, tool) [N]: removed
        from the ground-truth wrist force the run's metrics report. Shape (3,)."""
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
        self.phantom: PhantomHandle | None = phantom_handle(scenario, seed)
        self.cameras: dict[str, int] = {c.name: m.camera(c.name).id for c in scenario.cameras}
        """Camera name -> its id in the model (`MjData.cam_xpos[id]` is where it is)."""
        self.zones: dict[str, int] = {z.name: m.geom(z.name).id for z in scenario.scene.zones}
        """No-go zone name -> its (collision-free) box geom."""
        self.home = np.array(robot.home, dtype=float)
        self.contact_sensors: tuple[ContactSensor, ...] = bind_contact_sensors(
            m, contact_sensors or []
        )
        """The contact sensors the `collision` guard reads (world/contacts.py)."""
        self.effects = FaultEffects(
            m,
            self.data,
            {n: (h.body_id, h.geom_id) for n, h in self.objects.items()},
            self.finger_geoms,
        )
        """Changes faults make to the running world (an obstacle appears, a grip slips)."""
        self.step_clock = StepClock()
        """Simulated time [s], advanced by the step function (engine/step.py) with every
        `mj_step`: `MjData.time` without the bindings' property lookup."""
        self.reset()

    @classmethod
    def build(cls, scenario: Scenario, seed: int) -> World:
        """Assemble robot + table + objects + markers with MjSpec and compile them (the
        scenario's parcels, drawn for `seed`, become objects)."""
        scenario, parcel_classes = scenario.for_seed(seed)
        robot = get_robot(scenario.robot.name)
        if scenario.tool is not None:
            robot = mount_tool(robot, tool_from_spec(scenario.tool))
        g = scenario.robot.gains
        if g is not None:  # the controller built on this robot uses them
            robot.with_gains(
                robot.gains.replaced(
                    g.kp, g.kd, g.cartesian.stiffness, g.cartesian.damping,
                    g.cartesian.nullspace_stiffness,
                )
            )  # fmt: skip
        spec = robot.build_spec()
        for key in list(spec.keys):
            spec.delete(key)  # the world sets its initial state itself
        spec.modelname = f"{scenario.name}"
        spec.option.timestep = scenario.physics.timestep_s
        spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
        spec.option.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
        spec.option.impratio = 10.0
        # Free objects at rest sleep (MuJoCo's island sleeping): a resting block costs its
        # collisions and contact rows every step until something touches or pushes it (a
        # contact with an awake body, a velocity, an applied force wakes it). The robot never
        # sleeps (its trees are actuated). Measured: mj_step 173 -> 80 us a step on sorting,
        # 117 -> 75 us on mobile_search (docs/architecture.md, docs/performance.md).
        if scenario.physics.sleep:
            spec.option.enableflags |= SLEEP
        spec.body(robot.root_body).pos = scenario.robot.base_pos
        add_scene(spec, scenario, seed)
        add_phantom_scene(spec, scenario, seed)
        if scenario.scene.conveyor is not None:
            add_conveyor(spec, scenario.scene.conveyor)
        add_fault_obstacles(spec, scenario)
        add_cameras(spec, scenario, robot)
        tool: Tool | None = getattr(robot, "tool", None)
        touchable = {o.name for o in scenario.scene.objects}
        if scenario.scene.phantom is not None:
            touchable.add(scenario.scene.phantom.name)
        sensors = add_contact_sensors(
            spec,
            robot.root_body,
            robot.finger_bodies,
            f"{tool.name}_tip" if tool else None,
            touchable,
            _chassis(spec, robot.base_body),
            pushable={o.name for o in scenario.scene.objects},
        )
        model = spec.compile()
        tissue = {model.geom(scenario.scene.phantom.name).id} if scenario.scene.phantom else set()
        harden_contacts(model, tissue)
        set_tissue_stiffness(model, scenario, seed, robot)
        object_geoms = [model.body(o.name).geomadr[0] for o in scenario.scene.objects]
        randomize_appearance(model, scenario, seed, [int(g) for g in object_geoms])
        world = cls(scenario, seed, robot, model, sensors)
        world.parcel_classes = parcel_classes
        if scenario.scene.conveyor is not None:
            world.conveyor = ConveyorBelt(world, scenario.scene.conveyor)
        apply_joint_friction(model, robot, world.arm_dof, scenario.physics.realism)
        return world

    def engage_brake(self, joint: int, torque_nm: float | None = None) -> None:
        """Engage the holding brake of arm joint `joint` (0-based): a dry friction of
        `torque_nm` (default: the joint's torque limit) that holds it where it is.

        The brake is MuJoCo's friction loss made nearly rigid (`BRAKE_SOLIMP`): the default
        soft friction constraint lets a joint creep at a speed proportional to the load it
        holds (a Panda's shoulder sagged at 0.022-0.024 rad/s under gravity with its motor
        lost); at an impedance of 0.9999 the creep is below 1e-4 rad/s, and the brake still
        slips when a load beyond its holding torque pushes it, as a real one does.
        """
        dof = int(self.arm_dof[joint])
        self.model.dof_frictionloss[dof] = (
            float(self.arm_effort_limit[joint]) if torque_nm is None else torque_nm
        )
        self.model.dof_solimp[dof, :2] = BRAKE_SOLIMP
        self.model.dof_solref[dof, 0] = BRAKE_TIMECONST_S
        self.braked.add(joint)

    def release_brakes(self, keep: Iterable[int] = ()) -> None:
        """Release every holding brake `engage_brake` engaged but those of the joints in
        `keep` (a live session releases all before its next task, an `on_abort` response
        all but those of joints whose motor failed): the motors take over again."""
        kept = set(keep) & self.braked
        for joint in self.braked - kept:
            dof = int(self.arm_dof[joint])
            self.model.dof_frictionloss[dof] = self._friction0[joint]
            self.model.dof_solimp[dof] = self._solimp0[joint]
            self.model.dof_solref[dof] = self._solref0[joint]
        self.braked = kept

    def static_moved(self) -> None:
        """Recompute the world after a static body's model pose changed (`model.body_pos` or
        `body_quat` of a body without joints, e.g. a table raised in a test).

        With sleeping on (`physics.sleep`), MuJoCo places static bodies once, at reset, and
        never again: this runs one `mj_forward` with sleeping off, which places them and
        wakes every sleeping object (they fall asleep again once at rest).
        """
        m = self.model
        flags = m.opt.enableflags
        m.opt.enableflags = flags & ~SLEEP
        try:
            mujoco.mj_forward(m, self.data)
        finally:
            m.opt.enableflags = flags

    def reset(self) -> None:
        """Robot at home with the gripper open, objects at their seeded poses, at rest."""
        m, d = self.model, self.data
        mujoco.mj_resetData(m, d)
        self.step_clock.t = d.time
        d.qpos[self.arm_qpos] = self.home
        d.qpos[self.finger_qpos] = self.robot.gripper_open_m / self.robot.finger_m_per_unit
        d.ctrl[self.gripper_act] = 0.0  # the hand's motor off (engine/context.py drives it)
        for name, pos, quat in object_poses(self.scenario, self.seed):
            h = self.objects[name]
            d.qpos[h.qpos_adr : h.qpos_adr + 3] = pos
            d.qpos[h.qpos_adr + 3 : h.qpos_adr + 7] = quat
        mujoco.mj_forward(m, d)
        # Sensors at t = 0 read the arm held still, as it is from the first step on (with zero
        # torques they would read it falling); the runner sets the torques before stepping.
        d.ctrl[self.arm_act] = d.qfrc_bias[self.arm_dof]
        mujoco.mj_forward(m, d)


def _chassis(spec: mujoco.MjSpec, base_body: str | None) -> tuple[str, ...]:
    """A mobile base's chassis and the bodies welded to it (no joint between: the arm's own
    base link on top of it), by name; () for a robot without a base."""
    if base_body is None:
        return ()
    out, stack = [base_body], list(spec.body(base_body).bodies)
    while stack:
        body = stack.pop()
        if not body.joints:
            out.append(body.name)
            stack.extend(body.bodies)
    return tuple(out)


def _is_descendant(m: mujoco.MjModel, body: int, root: int) -> bool:
    while body > 0:
        if body == root:
            return True
        body = int(m.body_parentid[body])
    return root == 0
