"""Context: what a skill or a guard sees of the running episode.

The context holds the episode's state only (docs/architecture.md, "Lifetimes"): what lives as
long as the world — the hardware, its sensors and faults, the step loop — is the cell's
(engine/cell.py), which the context reads through. The members a skill may use are listed,
with where and at what cost, in docs/skill-api.md (generated from engine/skill_api.py); they
stay stable for users' own skills.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from ..exceptions import SkillError
from ..world.pose import Pose
from .blackboard import Blackboard
from .tasks import TaskLog

if TYPE_CHECKING:
    import mujoco

    from ..language.scenario import Scenario
    from ..perception.rig import CameraRig
    from ..robots import Controller, Robot
    from ..skills.ik import IKSolver
    from ..world.path import PlannedPath, TraceSpec
    from ..world.world import ObjectHandle
    from .hardware import Hardware

__all__ = ["Context", "Event"]


@dataclass(frozen=True)
class Event:
    """Something that happened at simulated time `t` [s]."""

    t: float
    kind: str
    message: str
    level: str = "INFO"
    data: dict[str, Any] | None = None


class Context:
    """The running episode as seen from a skill (every control tick) or a guard (every step).

    An episode's state lives here: the blackboard, the events, the metrics, the task log, the
    skills' clock, what the active skill aims at. One per `orchestrator run`; a fresh one per
    task of a live session. The world and the robot's hardware live longer, in the cell
    (engine/cell.py, `ctx.cell`): sensing goes through the accessors below, which read the
    cell's simulated sensors and encoders the way a robot's own software would.

    Args:
        cell: The world and the robot's hardware the episode runs on.
        blackboard: The episode's shared values (its machine's defaults and the scenario's).
    """

    def __init__(self, cell: Hardware, blackboard: Blackboard) -> None:
        world = cell.world
        self.cell: Hardware = cell
        """What lives as long as the world: its hardware, sensors and faults, the step loop
        (engine/cell.py; the framework's: a skill uses the context's other members)."""
        self.world = world
        """The episode's MuJoCo world: its objects (`world.objects`), markers, table height."""
        self.model: mujoco.MjModel = world.model
        """MuJoCo's model of the scene (ground truth: what the robot cannot know)."""
        self.data: mujoco.MjData = world.data
        """MuJoCo's state of the scene (ground truth; the framework steps it, never a skill)."""
        self.robot: Robot = world.robot
        """The robot: joints, limits, gains, home configuration (`robot.home`)."""
        self.scenario: Scenario = world.scenario
        """The validated scenario of the run."""
        self.controller: Controller = cell.controller
        """The torque controller a skill commands: `hold(q)`, `set_joint_target(q, qd, qdd)`,
        `set_cartesian_target(pos, rot)`, `hold_setpoint()`."""
        self.ik: IKSolver = cell.ik
        """The IK solver motion skills share (`orchestrator.skills.ik.IKSolver`)."""
        self.rng: np.random.Generator = cell.rng
        """The episode's random generator (seeded: a skill's noise is the same every run)."""
        self.dt_control = cell.dt_control
        """Control period: the time between two `step` calls [s] (0.01 at 100 Hz)."""
        self.dt_physics = cell.dt_physics
        """Physics step [s] (0.002 at 500 Hz)."""
        self.workspace_box: tuple[np.ndarray, np.ndarray] | None = cell.workspace_box
        """The box of the scenario's `workspace` guard, (min, max) [m]; None without one."""
        self.blackboard = blackboard
        """The run's shared values: `blackboard[key]`, `blackboard[key] = value`,
        `blackboard.resolve("$key")`."""
        self.clock_offset = 0.0
        """Simulated time pauses have taken off the skills' clock [s] (the executor's)."""
        self.clock_rate = 1.0
        """Speed of the skills' clock this tick (1 running, 0 held by a pause): a skill that
        advances per tick rather than on `clock` scales its increment by it."""
        self.grasped_at: dict[str, float] = {}
        """Height [m] of each object's centre when the fingers last closed on it (the `grasp`
        skill writes it): what a lift is measured from wherever the object had been moved to
        (`verify_grasp`, the `held` success check). Part of the episode: a snapshot keeps it."""
        self.events: list[Event] = []
        """Every event `log` recorded, in order."""
        self.listeners: list[Callable[[Event], None]] = []
        """Called with each event as it is logged (the recorder, a live session)."""
        self.metrics: dict[str, Any] = {}
        """Figures skills add to the result's `metrics` (e.g. force RMS error of a trace)."""
        self.tasks = TaskLog()
        """The task log the task skills (`next_task`, `end_task`) report to."""
        self.ik_target: Pose | None = None
        """The pose the active motion skill is driving the TCP to (for guards and recording)."""
        self.planned_path: PlannedPath | None = None
        """The path the active skill is moving the TCP along (for `path_deviation`)."""
        self.trace: TraceSpec | None = None
        """The path a contact skill is tracing now, for the ground-truth probe
        (engine/trace_truth.py); None when no trace runs."""
        self.keep_camera_shots = False
        """Skills keep the frames they look at in `camera_shots` (a recorder asks for it)."""
        self.camera_shots: list[tuple[int, float, Any, list[Any]]] = []
        """`(tick, t, Frame, detections)` of the camera frames skills looked at, while
        `keep_camera_shots`; the recorder takes them as it logs them."""
        # Views read every control tick, bound once (MjData never reallocates; a fresh view
        # through MjData's attributes costs more than the arithmetic done on it).
        self._tcp_pos = world.data.site_xpos[world.tcp_site]
        self._tcp_rot = world.data.site_xmat[world.tcp_site].reshape(3, 3)
        self._time = world.step_clock
        """Simulated time (`_time.t` [s]): `data.time` as the step function advances it,
        without the bindings' property lookup."""
        self._encoders = cell.encoders
        self._wrist = cell.wrist
        self._hand = cell.hand

    # -- time ---------------------------------------------------------------------------
    @property
    def t(self) -> float:
        """Simulated time [s]."""
        return self._time.t

    @property
    def clock(self) -> float:
        """The skills' clock [s]: simulated time minus the time pauses held the machine.

        Skills and state timeouts measure durations on it, so a `pause` freezes them and a
        `resume` continues where they were. Equal to `t` in a run without pauses.
        """
        return self._time.t - self.clock_offset

    @property
    def tick(self) -> int:
        """Control ticks run so far (on this world: a live task starts where the last ended)."""
        return self.cell.tick

    # -- proprioception -----------------------------------------------------------------
    @property
    def q(self) -> np.ndarray:
        """Arm joint angles as the encoders read them [rad]. Shape (n_arm,); a copy."""
        return self._encoders.read()[0][: self.robot.n_arm].copy()

    @property
    def qd(self) -> np.ndarray:
        """Arm joint velocities as the encoders read them [rad/s]. Shape (n_arm,); a copy."""
        return self._encoders.read()[1][: self.robot.n_arm].copy()

    def robot_q(self) -> tuple[np.ndarray, np.ndarray]:
        """Positions and velocities of all robot joints (arm, then fingers), as read."""
        return self._encoders.read()

    @property
    def tcp_pos(self) -> np.ndarray:
        """TCP position in the world [m]. Shape (3,)."""
        return self._tcp_pos

    @property
    def tcp_rot(self) -> np.ndarray:
        """TCP orientation in the world. Shape (3, 3)."""
        return self._tcp_rot

    @property
    def gripper_width(self) -> float:
        """Distance between the fingers [m]."""
        return self._hand.width()

    def wrist_force(self) -> np.ndarray:
        """External force on the hand in the world frame [N], hand weight removed. Shape (3,)."""
        return np.array(self._wrist.force())

    @property
    def wrist_force_norm_sq(self) -> Callable[[], float]:
        """Squared norm of `wrist_force()` [N^2], cheap enough for every physics step (computed
        once per step: the guards and the runner that ask share it). Call it:
        `ctx.wrist_force_norm_sq()`."""
        return self._wrist.norm_sq

    @property
    def joint_torque(self) -> np.ndarray:
        """Torque each arm joint's torque sensor measures: what its motor delivers [Nm].
        Shape (n_arm,); a view."""
        return self.data.actuator_force[self.world.arm_act_index]

    def wrist_force_age_s(self) -> float:
        """Time since the wrist force reading last updated [s] (its timestamp; 0 when live)."""
        return self._wrist.age_s()

    def zero_wrist_force(self, offset: np.ndarray) -> None:
        """Zero the wrist sensor: `offset` [N] (world frame, shape (3,), e.g. the mean reading
        at rest with a tool mounted) is removed from every later `wrist_force()` reading."""
        self._wrist.zero(offset)

    # -- commands -----------------------------------------------------------------------
    def set_gripper(self, opening_m: float) -> None:
        """Command each finger's opening [m] (0 closes with the gripper's full force).

        The fingers travel there at the gripper's speed (`robot.gripper_speed_mps`), as a real
        hand does: its drive (robots/hand.py) advances the setpoint every control tick.
        """
        self._hand.target = float(opening_m)

    @property
    def gripper_target(self) -> float:
        """Each finger's commanded opening [m] (`set_gripper` sets it; the fingers travel to it
        at the gripper's speed)."""
        return self._hand.target

    @property
    def gripper_commanded(self) -> bool:
        """The gripper's reference has reached `gripper_target` (closing on an object: it
        squeezes with the whole grip force)."""
        return self._hand.commanded

    # -- world knowledge (ground truth; perception skills add noise) ---------------------
    def object_handle(self, name: str) -> ObjectHandle:
        """Indices of a scene object; an unknown name is a SkillError listing the valid ones."""
        try:
            return self.world.objects[name]
        except KeyError:
            valid = ", ".join(sorted(self.world.objects)) or "none"
            raise SkillError(f"unknown object {name!r} (valid: {valid})") from None

    def object_pose(self, name: str) -> Pose:
        """True pose of a scene object."""
        h = self.object_handle(name)
        q = self.data.qpos
        return Pose(
            pos=q[h.qpos_adr : h.qpos_adr + 3].tolist(),
            quat=q[h.qpos_adr + 3 : h.qpos_adr + 7].tolist(),
        )

    def start_pose(self, name: str) -> Pose:
        """Where a scene object started: its pose when the episode began (the scenario's `xy`
        and `yaw_deg` plus this seed's `randomize` draw, standing on its surface). A parcel
        of a conveyor or a shift, made during the run, has none: a SkillError."""
        from ..world.randomization import object_poses

        for obj, pos, quat in object_poses(self.scenario, self.world.seed):
            if obj == name:
                return Pose(pos=pos.tolist(), quat=quat.tolist())
        self.object_handle(name)  # an unknown name: the error lists the valid ones
        raise SkillError(f"{name!r} was not in the scene when the episode began")

    @property
    def cameras(self) -> CameraRig:
        """The scenario's cameras (the renderer opens on first use, not before)."""
        return self.cell.cameras

    def perceived(self, pose: Pose) -> Pose | None:
        """What perception reports for an object at `pose`: every perception skill passes its
        result through here, so injected perception faults (a miss, an offset) reach it."""
        return self.cell.perception.observe(pose)

    # -- events -------------------------------------------------------------------------
    def log(self, kind: str, message: str, level: str = "INFO", **data: Any) -> None:
        """Record an event at the current simulated time."""
        event = Event(self.t, kind, message, level, data or None)
        self.events.append(event)
        for listener in self.listeners:
            listener(event)
