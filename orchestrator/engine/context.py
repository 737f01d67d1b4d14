"""Context: what a skill or a guard sees of the running episode."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from ..exceptions import SkillError
from ..perception.rig import CameraRig
from ..world.actuators import ActuatorFault
from ..world.native import native
from ..world.pose import Pose
from ..world.random_streams import stream
from ..world.realism import WristForceNoise
from ..world.sensors import JointEncoders, PerceptionFaults, WristForceFault
from ..world.world import as_index
from .blackboard import Blackboard
from .tasks import TaskLog

if TYPE_CHECKING:
    import mujoco

    from ..language.scenario import Scenario
    from ..robots import Controller, Robot
    from ..world.path import PlannedPath, TraceSpec
    from ..world.world import ObjectHandle, World

__all__ = ["Context", "Event"]

_GRIP_CONTACT_M = 0.002
"""A closing finger still this far short of its target is blocked by an object [m]."""
_GRIP_HELD = 0.5
"""A finger that moved less than this fraction of what its voltage would move it free is held
back by something (the drive's current limit applies; closing, it is blocked)."""
_GRIP_STILL_TICKS = 2
"""Control ticks a closing finger must stay held back, short of its target, to be blocked."""
_GRIP_LEAD_M = 0.001
"""Farthest a finger's reference runs ahead of the finger while moving [m]."""
GRIP_SERVO_GAIN = 0.5
"""Fraction of a finger's position error the hand's drive takes out per control tick (the
motor answers within a physics step: at 1 the servo is deadbeat)."""
GRIP_MOVE_FORCE_FRACTION = 0.1
"""The hand's drive limits its motor's force to this fraction of the grip force while the
fingers move (5 N of the Panda's 20 N; the full force is for squeezing), as a current limit:
the voltage is capped at what pushes with that force at the fingers' measured speed. A DC
motor that meets an object at full speed stalls at once and, without the limit, strikes it
with its whole stall force (16 N at the wrist as a finger knocked a pick_place cube against
the table, seed 2). The drive acts once per control tick, so the first 10 ms of an impact
can still see the stall force."""
GRIP_SPEED_MARGIN = 0.95
"""Fraction of the motor's speed the drive runs the fingers at, moving: the rest is for what
pushes them (a squeezed object springing back as they open pushed them 2 % past the motor's
0.05 m/s at full voltage), as the arm's commands keep 15 % of its limits (`COMMAND_MARGIN`)."""
GRIP_OPEN_SPEED_MARGIN = 0.9
"""Fraction of the motor's speed the drive opens the fingers at: a released object that
slides down between them wedges them apart, back-driving the motor (a tilted sorting parcel
pushed with 2.6 N, the fingers ran at 0.0507 m/s with the voltage at 0.95, seed 1; the motor
gives v_max (u + F_push / F_stall))."""
GRIP_SQUEEZE_RAMP_S = 0.1
"""Time the drive takes to raise the force from the moving limit to the full grip force once
the fingers are blocked by what they grasp [s] (at once: 12 N at the wrist on pick_place's
cube, seed 1, against 5 N before this hand model)."""


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

    Sensing goes through the accessors below: they read the simulated sensors and encoders,
    the way a robot's own software would.
    """

    def __init__(
        self,
        world: World,
        controller: Controller,
        blackboard: Blackboard,
        rng: np.random.Generator,
        dt_control: float,
    ) -> None:
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
        self.controller = controller
        """The torque controller a skill commands: `hold(q)`, `set_joint_target(q, qd, qdd)`,
        `set_cartesian_target(pos, rot)`, `hold_setpoint()`."""
        self.blackboard = blackboard
        """The run's shared values: `blackboard[key]`, `blackboard[key] = value`,
        `blackboard.resolve("$key")`."""
        self.rng = rng
        """The episode's random generator (seeded: a skill's noise is the same every run)."""
        self.dt_control = dt_control
        """Control period: the time between two `step` calls [s] (0.01 at 100 Hz)."""
        self.dt_physics = float(world.model.opt.timestep)
        """Physics step [s] (0.002 at 500 Hz)."""
        self.tick = 0
        """Control ticks run so far."""
        self.clock_offset = 0.0
        """Simulated time pauses have taken off the skills' clock [s] (the executor's)."""
        self.clock_rate = 1.0
        """Speed of the skills' clock this tick (1 running, 0 held by a pause): a skill that
        advances per tick rather than on `clock` scales its increment by it."""
        self.gripper_target = world.robot.gripper_open_m
        """Each finger's commanded opening [m] (`set_gripper` sets it; the fingers travel to it
        at the gripper's speed)."""
        self.grasped_at: dict[str, float] = {}
        """Height [m] of each object's centre when the fingers last closed on it (the `grasp`
        skill writes it): what a lift is measured from wherever the object had been moved to
        (`verify_grasp`, the `held` success check). Part of the episode: a snapshot keeps it."""
        self.events: list[Event] = []
        """Every event `log` recorded, in order."""
        self.listeners: list[Callable[[Event], None]] = []
        """Called with each event as it is logged (the recorder, a live session)."""
        # Views read every control tick or physics step, bound once (MjData never reallocates;
        # a fresh view through MjData's attributes costs more than the arithmetic done on it).
        d = self.data
        self._tcp_pos = d.site_xpos[world.tcp_site]
        self._tcp_rot = d.site_xmat[world.tcp_site].reshape(3, 3)
        self._ctrl = d.ctrl
        finger_index = as_index(world.finger_qpos)
        self._fingers = d.qpos[finger_index] if isinstance(finger_index, slice) else None
        self._two_fingers = self._fingers is not None and len(self._fingers) == 2
        self._grip_ref = world.robot.gripper_open_m
        """Where the hand's drive is taking each finger [m]: the reference it servoes to."""
        self._grip_volt_step = world.robot.gripper_speed_mps * dt_control
        """How far a free finger goes in a control tick at full voltage [m]."""
        self._grip_gain = GRIP_SERVO_GAIN / self._grip_volt_step
        """Motor voltage per metre of finger error [1/m]."""
        self._grip_limit = 1.0
        """The drive's limit on the motor voltage this tick (its current limit)."""
        self._grip_still = 0
        """Control ticks the closing fingers have been held back short of their target."""
        self._grip_squeeze: float | None = None
        """Where the fingers were blocked, while they squeeze [m]; None otherwise."""
        self._grip_prev = world.robot.gripper_open_m
        """The finger's position at the last control tick [m]."""
        self._grip_ramp = dt_control / GRIP_SQUEEZE_RAMP_S * (1.0 - GRIP_MOVE_FORCE_FRACTION)
        """Rise of that limit per control tick while squeezing."""
        self._norm_sq_t = -1.0
        self._norm_sq = 0.0
        self._sensed_t = math.nan
        self._sensed = (0.0, 0.0, 0.0)
        self._bias: tuple[float, ...] = tuple(world.wrist_bias_world.tolist())
        """`world.wrist_bias_world` as floats (only `zero_wrist_force` changes it)."""
        self._true_weight: tuple[float, ...] = tuple(world.wrist_weight_world.tolist())
        """`world.wrist_weight_world` as floats: the true weight of the hand and its tool."""
        # The wrist sensor's raw reading and the rotation of its site, read every physics step
        # as plain floats: a 3x3 matrix-vector product in numpy costs more in call overhead
        # than in arithmetic.
        self._f_site = d.sensordata[world.force_adr : world.force_adr + 3]
        self._wrist_rot = d.site_xmat[world.wrist_site]
        self.metrics: dict[str, Any] = {}
        """Figures skills add to the result's `metrics` (e.g. force RMS error of a trace)."""
        self.tasks = TaskLog()
        """The task log the task skills (`next_task`, `end_task`) report to."""
        self.ik: Any = None
        """The IK solver motion skills share (`orchestrator.skills.ik.IKSolver`)."""
        self.ik_target: Pose | None = None
        """The pose the active motion skill is driving the TCP to (for guards and recording)."""
        self.planned_path: PlannedPath | None = None
        """The path the active skill is moving the TCP along (for `path_deviation`)."""
        self.trace: TraceSpec | None = None
        """The path a contact skill is tracing now, for the ground-truth probe
        (engine/trace_truth.py); None when no trace runs."""
        self.workspace_box: tuple[np.ndarray, np.ndarray] | None = None
        """The box of the scenario's `workspace` guard, (min, max) [m]; None without one (set
        by `make_context`)."""
        self.sensor_faults = np.zeros(2)
        """Flags of the sensor faults in effect, shape (2,): [0] the wrist force sensor's
        (`ft_fault` set), [1] a joint encoder's (until the safety channel takes over). 1.0 or
        0.0; read by `sensor_health`'s envelope (guards/bank.py)."""
        realism = world.scenario.physics.realism
        quantize = realism.enabled and realism.encoder_quantization
        self.ft_noise: WristForceNoise | None = (
            WristForceNoise(
                realism.ft_noise_n, realism.ft_drift_n_per_sqrt_s, world.seed, self.dt_physics
            )
            if realism.enabled and (realism.ft_noise_n > 0 or realism.ft_drift_n_per_sqrt_s > 0)
            else None
        )
        """Noise and bias drift of the wrist force sensor (`physics.realism`), if on."""
        self._time = world.step_clock
        """Simulated time (`_time.t` [s]): `data.time` as the step function advances it,
        without the bindings' property lookup (~0.5 us with cold caches, ~1,500 reads a second
        of simulated time by the encoders, the wrist force, the skills and the runner)."""
        ext = native()
        self._wf: Any = None
        """The wrist force computed in C (world/native.py), None on the pure-Python path."""
        if ext is not None and (self.ft_noise is None or self.ft_noise.compiled is not None):
            noise = None if self.ft_noise is None else self.ft_noise.compiled
            self._wf = ext.WristForce(
                self._time, self._f_site, self._wrist_rot, self._bias, self._true_weight, noise
            )
            # the two readings of every physics step, one C call each
            self.wrist_force_norm_sq = self._wf.norm_sq  # type: ignore[method-assign]
            self.true_wrist_force_norm_sq = self._wf.true_norm_sq  # type: ignore[method-assign]
        self.encoders = JointEncoders(
            self.data.qpos,
            self.data.qvel,
            as_index(world.robot_qpos),
            as_index(world.robot_dof),
            world.robot.n_arm,
            stream(world.seed, "encoders"),
            world.robot.encoder_resolution_rad if quantize else 0.0,
            self._time,
            status=self.sensor_faults[1:],
        )
        """The joint encoders the controller, the skills and `sensor_health` read."""
        self._ft_fault: WristForceFault | None = None
        self.actuator_fault: ActuatorFault | None = None
        """An injected motor fault, if any (the runner applies it to the commanded torques)."""
        self.perception = PerceptionFaults()
        """Perception faults; every perception skill reports through `perceived()`."""
        self._cameras: CameraRig | None = None
        self.keep_camera_shots = False
        """Skills keep the frames they look at in `camera_shots` (a recorder asks for it)."""
        self.camera_shots: list[tuple[int, float, Any, list[Any]]] = []
        """`(tick, t, Frame, detections)` of the camera frames skills looked at, while
        `keep_camera_shots`; the recorder takes them as it logs them."""

    @property
    def ft_fault(self) -> WristForceFault | None:
        """An injected fault of the wrist force sensor, if any."""
        return self._ft_fault

    @ft_fault.setter
    def ft_fault(self, fault: WristForceFault | None) -> None:
        self._ft_fault = fault
        self.sensor_faults[0] = 0.0 if fault is None else 1.0
        self._norm_sq_t = -1.0  # the fault acts from now on: a new reading
        if self._wf is not None:  # the C reading hands over to Python while a fault acts
            self._wf.set_fallback(None if fault is None else self._faulted_norm_sq)

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

    # -- proprioception -----------------------------------------------------------------
    @property
    def q(self) -> np.ndarray:
        """Arm joint angles as the encoders read them [rad]. Shape (n_arm,); a copy."""
        return self.encoders.read()[0][: self.robot.n_arm].copy()

    @property
    def qd(self) -> np.ndarray:
        """Arm joint velocities as the encoders read them [rad/s]. Shape (n_arm,); a copy."""
        return self.encoders.read()[1][: self.robot.n_arm].copy()

    def robot_q(self) -> tuple[np.ndarray, np.ndarray]:
        """Positions and velocities of all robot joints (arm, then fingers), as read."""
        return self.encoders.read()

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
        if self._two_fingers:  # numpy's sum of two, the same float: it adds them to 0.0
            a, b = self._fingers.tolist()  # (so two -0.0 sum to 0.0, as numpy's does)
            return 0.0 + a + b
        # other hands (a revolute jaw: robots/so101): each joint's coordinate in metres of
        # its side's opening (`Robot.finger_m_per_unit`), the two sides' sum the gap
        q = self.data.qpos[self.world.finger_qpos]
        return float(q.sum()) * self.world.robot.finger_m_per_unit * 2.0 / len(q)

    def wrist_force(self) -> np.ndarray:
        """External force on the hand in the world frame [N], hand weight removed. Shape (3,)."""
        return np.array(self._wrist_force_xyz())

    def wrist_force_norm_sq(self) -> float:
        """Squared norm of `wrist_force()` [N^2], cheap enough for every physics step (computed
        once per step: the guards and the runner that ask share it)."""
        now = self._time.t
        if now == self._norm_sq_t:
            return self._norm_sq
        # `_wrist_force_xyz` written out: this runs every physics step, where every call and
        # attribute lookup counts (the caches are cold after mj_step)
        rx, ry, rz = self._sensed if now == self._sensed_t else self._sensed_world(now)
        bx, by, bz = self._bias
        fx, fy, fz = bx - rx, by - ry, bz - rz
        noise = self.ft_noise
        if noise is not None:
            ox, oy, oz = noise.offset(now)
            fx, fy, fz = fx + ox, fy + oy, fz + oz
        if self._ft_fault is not None:
            fx, fy, fz = self._ft_fault.apply((fx, fy, fz), now)
        norm_sq = fx * fx + fy * fy + fz * fz
        self._norm_sq, self._norm_sq_t = norm_sq, now
        return norm_sq

    def _faulted_norm_sq(self) -> float:
        """`wrist_force_norm_sq` on the compiled path while a sensor fault acts (the compiled
        reading calls it and caches the result for the instant)."""
        now = self._time.t
        fx, fy, fz = self._wf.measured(now)
        if self._ft_fault is not None:
            fx, fy, fz = self._ft_fault.apply((fx, fy, fz), now)
        return fx * fx + fy * fy + fz * fz

    def true_wrist_force_norm_sq(self) -> float:
        """Squared norm of the true external force on the wrist [N^2]: the noise-free sensor
        with the true weight of the hand and its tool removed (a perfect zero). Ground truth
        for the run's metrics, read every physics step; never what a skill or guard sees.
        (The pure-Python path; where compiled, the context's `WristForce` answers it.)"""
        rx, ry, rz = self._sensed_world(self._time.t)
        bx, by, bz = self._true_weight
        fx, fy, fz = bx - rx, by - ry, bz - rz
        return fx * fx + fy * fy + fz * fz

    def true_wrist_force(self) -> tuple[float, float, float]:
        """The true external force on the wrist, world frame [N] (see
        `true_wrist_force_norm_sq`): ground truth, never what a skill or guard sees."""
        rx, ry, rz = self._sensed_world(self._time.t)
        bx, by, bz = self._true_weight
        return (bx - rx, by - ry, bz - rz)

    def _sensed_world(self, now: float) -> tuple[float, float, float]:
        """The wrist sensor's raw reading rotated into the world frame [N] at simulated time
        `now` [s], computed once per instant: the true force (metrics, every step) and the
        measured one (guards, every step) share it."""
        if self._wf is not None:
            return self._wf.sensed(now)
        if now == self._sensed_t:
            return self._sensed
        f0, f1, f2 = self._f_site.tolist()
        r0, r1, r2, r3, r4, r5, r6, r7, r8 = self._wrist_rot.tolist()
        sensed = (
            r0 * f0 + r1 * f1 + r2 * f2,
            r3 * f0 + r4 * f1 + r5 * f2,
            r6 * f0 + r7 * f1 + r8 * f2,
        )
        self._sensed, self._sensed_t = sensed, now
        return sensed

    def _wrist_force_xyz(self, now: float | None = None) -> tuple[float, float, float]:
        if now is None:
            now = self._time.t
        if self._wf is not None:
            f = self._wf.measured(now)
            return f if self._ft_fault is None else self._ft_fault.apply(f, now)
        rx, ry, rz = self._sensed_world(now)
        bx, by, bz = self._bias
        f = (bx - rx, by - ry, bz - rz)
        if self.ft_noise is not None:
            f = self.ft_noise.apply(f, now)
        if self._ft_fault is not None:
            return self._ft_fault.apply(f, now)
        return f

    @property
    def joint_torque(self) -> np.ndarray:
        """Torque each arm joint's torque sensor measures: what its motor delivers [Nm].
        Shape (n_arm,); a view."""
        return self.data.actuator_force[self.world.arm_act_index]

    def wrist_force_age_s(self) -> float:
        """Time since the wrist force reading last updated [s] (its timestamp; 0 when live)."""
        return 0.0 if self._ft_fault is None else self._ft_fault.age_s(self._time.t)

    def zero_wrist_force(self, offset: np.ndarray) -> None:
        """Zero the wrist sensor: `offset` [N] (world frame, shape (3,), e.g. the mean reading
        at rest with a tool mounted) is removed from every later `wrist_force()` reading."""
        self.world.wrist_bias_world -= np.asarray(offset, dtype=float)
        self._bias = tuple(self.world.wrist_bias_world.tolist())
        self._norm_sq_t = -1.0
        if self._wf is not None:
            self._wf.set_bias(self._bias)

    # -- commands -----------------------------------------------------------------------
    def set_gripper(self, opening_m: float) -> None:
        """Command each finger's opening [m] (0 closes with the gripper's full force).

        The fingers travel there at the gripper's speed (`robot.gripper_speed_mps`), as a real
        hand does: the runner advances the setpoint every control tick (`advance_gripper`).
        """
        self.gripper_target = float(opening_m)

    @property
    def gripper_commanded(self) -> bool:
        """The gripper's reference has reached `gripper_target` (closing on an object: it
        squeezes with the whole grip force)."""
        return self._grip_ref == self.gripper_target and (
            self._grip_squeeze is None or self._grip_limit >= 1.0
        )

    def advance_gripper(self, rate: float = 1.0) -> None:
        """The hand's drive, one control tick: move each finger's reference towards
        `gripper_target` at `rate` times the gripper's speed (a pause slows it to 0), never more
        than `_GRIP_LEAD_M` ahead of the finger, and set the motor's voltage to follow it
        (feed-forward of the reference's speed plus the position error; the plant's motor caps
        the speed, robots/panda/model.py), its force limited to `GRIP_MOVE_FORCE_FRACTION` of
        the grip force while the fingers move. Closing fingers that stay still short of the
        target are blocked by what they grasp: they squeeze, the force rising to the motor's
        whole stall force over `GRIP_SQUEEZE_RAMP_S`, until the target opens or they reach it
        (an object that slips out of the grasp: they close on after it, as a real hand's grasp
        command does)."""
        goal = self.gripper_target
        finger = 0.5 * self.gripper_width
        moved, self._grip_prev = finger - self._grip_prev, finger
        ref = self._grip_ref
        if goal > ref:  # opening: from where the fingers are, not from a squeezing reference
            ref = max(ref, finger)
        short = goal < finger - _GRIP_CONTACT_M
        # what the last tick's voltage would have moved a free finger [m]; only a finger the
        # drive pushed can be held back (not one a pause holds still)
        free = abs(self._ctrl[self.world.gripper_act]) * self._grip_volt_step
        if self._grip_squeeze is not None:  # until the target opens or the fingers reach it
            if not short:  # (an object that slips out: they close on, at the motor's speed)
                self._grip_squeeze, self._grip_still = None, 0
        else:
            pushed = rate > 0.0 and free > GRIP_MOVE_FORCE_FRACTION * self._grip_volt_step
            held = short and pushed and -moved < _GRIP_HELD * free
            self._grip_still = self._grip_still + 1 if held else 0
            if self._grip_still >= _GRIP_STILL_TICKS:
                self._grip_squeeze = finger
        squeeze = self._grip_squeeze is not None
        if squeeze:
            ref = goal
        margin = GRIP_OPEN_SPEED_MARGIN if goal > finger else GRIP_SPEED_MARGIN
        step = margin * self._grip_volt_step * rate
        new = goal if abs(goal - ref) <= step else ref + math.copysign(step, goal - ref)
        if not squeeze:  # a reference that runs away from the finger would wind up
            new = min(max(new, finger - _GRIP_LEAD_M), finger + _GRIP_LEAD_M)
        self._grip_ref = new
        voltage = (new - ref) / self._grip_volt_step + self._grip_gain * (new - finger)
        if squeeze:  # the force rises to the full grip force
            limit = min(self._grip_limit + self._grip_ramp * rate, 1.0)
        elif abs(moved) >= _GRIP_HELD * free:  # the fingers went where the voltage sent them
            limit = margin
        else:  # held back: the current limit, stall force x (voltage - speed / v_max) <= move
            limit = min(GRIP_MOVE_FORCE_FRACTION + abs(moved) / self._grip_volt_step, margin)
        self._grip_limit = limit
        self._ctrl[self.world.gripper_act] = min(max(voltage, -limit), limit)

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
        if self._cameras is None:
            self._cameras = CameraRig(self.model, self.scenario, self.world.seed)
        return self._cameras

    def close(self) -> None:
        """Free what the episode holds outside Python (a camera's OpenGL context)."""
        if self._cameras is not None:
            self._cameras.close()
            self._cameras = None

    def perceived(self, pose: Pose) -> Pose | None:
        """What perception reports for an object at `pose`: every perception skill passes its
        result through here, so injected perception faults (a miss, an offset) reach it."""
        return self.perception.observe(pose)

    # -- events -------------------------------------------------------------------------
    def log(self, kind: str, message: str, level: str = "INFO", **data: Any) -> None:
        """Record an event at the current simulated time."""
        event = Event(self.t, kind, message, level, data or None)
        self.events.append(event)
        for listener in self.listeners:
            listener(event)
