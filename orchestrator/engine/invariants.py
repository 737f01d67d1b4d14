"""Invariants of every run, measured from MuJoCo's truth: the result's `invariants` section.

An `InvariantsObserver` rides along every episode `drive` runs (a per-step observer, like the
recorder). After every physics step it reads the plant's true joint velocities and actuator
torques and keeps the worst ratio to the datasheet, and the first step that crossed it:

* `joint_velocity`: every arm joint's |q̇| within the robot's velocity limits;
* `joint_acceleration`: every arm joint's |Δq̇ / Δt| within the robot's acceleration limits;
  the controlled stop of an abort is the one exemption: while it runs, and while the holding
  brakes it engages take the arm, the limit is the stop's documented deceleration
  (`physics.safe_stop.max_decel_rad_s2`) times `STOP_OVERSHOOT`;
* `joint_torque`: every arm motor below its effort limit (a motor at its limit was commanded
  more than the datasheet allows: what it delivered is not what the controller asked);
* `finger_speed`: every finger no faster than the hand's rated speed (0.05 m/s on the Panda).

At the end of the run (`on_end`) it judges the result:

* `task_log`: every parcel's final pose agrees with its task-log outcome (a parcel logged
  `dropped` is not still held between the fingers) and no object moved more than
  `MOVED_M` except while a task about that object ran;
* `reason`: every outcome other than `succeeded` has a reason whose message names the state
  and the cause.

The section is `{"ok": bool, "violations": [...], "worst": {...}}`; a violation names the
invariant, the joint or object, the value, the limit, the simulated time and the state.
`run --strict` and `batch --strict` turn a violation into exit 1.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from functools import partial
from operator import mul, sub
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from .context import Context
    from .executor import Executor
    from .result import RunResult

__all__ = [
    "FINGER_SPEED_MPS",
    "INVARIANTS",
    "MOVED_M",
    "STOP_OVERSHOOT",
    "InvariantsObserver",
    "first_violation",
]

INVARIANTS = (
    "joint_velocity",
    "joint_acceleration",
    "joint_torque",
    "finger_speed",
    "task_log",
    "reason",
)
"""Every invariant's name, in the order a report lists them."""

STOP_OVERSHOOT = 1.25
"""A controlled stop brakes along a profile at `max_decel_rad_s2`; the arm overshoots a
profile by ~20 % (engine/safety_stop.py), and the holding brakes lock the stopped arm: within
this factor of the documented deceleration it is the stop doing what it says."""
SATURATED = 0.999
"""A motor at or above this fraction of its effort limit is at its limit."""
FINGER_SPEED_MPS = 0.05
"""The Franka Hand's rated finger speed [m/s] (a robot's own `gripper_speed_mps` if set)."""
FINGER_TOLERANCE = 1.0 + 1e-6
"""Float noise on the finger speed's comparison."""
MOVED_M = 0.02
"""An object displaced further than this from where it rested moved [m]."""
MOVED_EVERY = 10
"""Control ticks between two looks at the objects (10 Hz at 100 Hz control: a task lasts
seconds, so which one ran when an object moved is not missed; looking every tick cost about
as much as the per-step checks on sorting)."""


def _num(x: float) -> float:
    return round(float(x), 6)


class InvariantsObserver:
    """Measures the invariants of one episode (see the module docstring).

    Attributes:
        violations: What crossed a limit, the first occurrence of each (invariant, joint).
        first_t: Simulated time of the first violation [s] (None: none yet).
    """

    def __init__(self) -> None:
        self.violations: list[dict[str, Any]] = []
        self.first_t: float | None = None
        self.from_t: float | None = None

    # -- the run's start ----------------------------------------------------------------------
    def on_start(self, ctx: Context, executor: Executor) -> None:
        w, data, model = ctx.world, ctx.data, ctx.model
        robot = ctx.robot
        self.ctx, self.executor = ctx, executor
        self.dof = np.asarray(w.arm_dof, dtype=np.intp)
        n = len(self.dof)
        self.vlim = np.asarray(robot.joint_velocity_limits(), float)[:n]
        self.alim = np.asarray(robot.acceleration_limits, float)[:n]
        self.tlim = np.abs(np.asarray(w.arm_effort_limit, float))[:n]
        self.act = np.asarray(w.arm_act, dtype=np.intp)
        self.dt = float(ctx.dt_physics)
        self.stop_decel = float(ctx.scenario.physics.safe_stop.max_decel_rad_s2) * STOP_OVERSHOOT
        self.finger_dof = np.asarray(
            [int(model.jnt_dofadr[model.joint(j).id]) for j in robot.finger_joints], dtype=np.intp
        )
        self.finger_lim = float(getattr(robot, "gripper_speed_mps", FINGER_SPEED_MPS))
        # [m] of a finger's travel per unit of its joint: 1 for a slide, the jaw's radius (per
        # side) for a revolute jaw, whose joint speed is in rad/s (the SO-101's read 0.071
        # rad/s against 0.05 m/s as 1.42x its rated speed)
        self.finger_gear = float(robot.finger_m_per_unit)
        # The step runs 500 times per simulated second next to a ~35 us mj_step: its readings
        # are bound once as views (or one gather where not contiguous), made Python lists and
        # compared with `map` (measured: ~6 us; the same in numpy, one array op each, ~22 us).
        self.read_arm = _reader(data.qvel, self.dof)
        self.read_fingers = _reader(data.qvel, self.finger_dof)
        self.read_torque = _reader(data.actuator_force, self.act)
        self.inv_v = (1.0 / self.vlim).tolist()
        self.inv_f = [self.finger_gear / self.finger_lim] * len(self.finger_dof)
        self.inv_a = (1.0 / (self.dt * self.alim)).tolist()  # |Δq̇| * this = |Δq̇/Δt| / limit
        self.inv_t = (1.0 / self.tlim).tolist()
        self.prev = self.read_arm()
        self.ticks = 0
        self.worst_v = self.worst_f = self.worst_a = self.worst_t = 0.0
        self.worst_a_stop = 0.0
        self.seen: set[tuple[str, int]] = set()
        # the end-of-run checks: where each object rested, and who moved it
        self.names = list(w.objects)
        self.body_ids = np.asarray([h.body_id for h in w.objects.values()], dtype=np.intp)
        self.rest = data.xpos[self.body_ids].copy()
        self.moved_under: dict[str, set[str | None]] = {}
        self.belt = w.conveyor is not None

    def on_resume(self, ctx: Context, executor: Executor) -> None:
        """A run restored from a snapshot: measured from here on (the section's `from_t`:
        a snapshot holds the run's state, not this observer's)."""
        self.on_start(ctx, executor)
        self.from_t = ctx.t

    # -- every physics step ---------------------------------------------------------------------
    def on_step(self, ctx: Context) -> None:
        v = self.read_arm()
        rv = max(map(mul, map(abs, v), self.inv_v))
        ra = max(map(mul, map(abs, map(sub, v, self.prev)), self.inv_a))
        rt = max(map(mul, map(abs, self.read_torque()), self.inv_t))
        fingers = self.read_fingers()
        rf = max(map(mul, map(abs, fingers), self.inv_f)) if fingers else 0.0
        if rv > 1.0 or ra > 1.0 or rt >= SATURATED or rf > FINGER_TOLERANCE:
            self._slow(v, fingers)
        if rv > self.worst_v:  # noqa: PLR1730 (cheaper than max() per step)
            self.worst_v = rv
        if rt > self.worst_t:  # noqa: PLR1730 (cheaper than max() per step)
            self.worst_t = rt
        if rf > self.worst_f:  # noqa: PLR1730 (cheaper than max() per step)
            self.worst_f = rf
        if ra > self.worst_a and not self._stopping():
            self.worst_a = ra
        self.prev = v

    def _stopping(self) -> bool:
        """An abort's controlled stop runs (or its brakes hold the arm): the exemption."""
        ex = self.executor
        stop = ex.stop
        return ex.violation is not None and stop is not None and not stop.gentle

    def _slow(self, v: list[float], fingers: list[float]) -> None:
        """A step that crossed a limit: record the first crossing per invariant and joint."""
        speed = np.abs(v)
        for j in np.flatnonzero(speed > self.vlim).tolist():
            self._violate("joint_velocity", j, speed[j], self.vlim[j], "rad/s")
        for j, f in enumerate(fingers):
            speed_mps = abs(f) * self.finger_gear
            if speed_mps > self.finger_lim * FINGER_TOLERANCE:
                self._violate("finger_speed", j, speed_mps, self.finger_lim, "m/s")
        accel = np.abs(np.subtract(v, self.prev)) / self.dt
        if self._stopping():
            self.worst_a_stop = max(self.worst_a_stop, float(accel.max()) / self.stop_decel)
            for j in np.flatnonzero(accel > self.stop_decel).tolist():
                self._violate(
                    "joint_acceleration", j, accel[j], self.stop_decel, "rad/s^2",
                    f"during the controlled stop (its documented deceleration x "
                    f"{STOP_OVERSHOOT:g})",
                )  # fmt: skip
        else:
            for j in np.flatnonzero(accel > self.alim).tolist():
                self._violate("joint_acceleration", j, accel[j], self.alim[j], "rad/s^2")
        torque = np.abs(self.read_torque())
        for j in np.flatnonzero(torque >= SATURATED * self.tlim).tolist():
            self._violate("joint_torque", j, torque[j], self.tlim[j], "N m")

    def _violate(
        self, name: str, joint: int, value: float, limit: float, unit: str, note: str = ""
    ) -> None:
        key = (name, joint)
        if key in self.seen:
            return
        self.seen.add(key)
        what = "finger" if name == "finger_speed" else "joint"
        state = self.executor.leaf
        t = self.ctx.t
        self.violations.append({
            "invariant": name,
            "message": f"{what} {joint + 1}: {value:.4g} {unit} over its limit {limit:.4g} "
            f"{unit} at t={t:.3f} s in state {state}" + (f" {note}" if note else ""),
            "value": _num(value), "limit": _num(limit), "t": _num(t), "state": state,
        })  # fmt: skip
        if self.first_t is None:
            self.first_t = t

    # -- every control tick: who moves which object -------------------------------------------
    def on_tick(self, ctx: Context, executor: Executor) -> None:
        if self.belt or not self.names:
            return  # a belt moves its parcels: a conveyor cell's log judges them at the feed
        self.ticks += 1
        if self.ticks % MOVED_EVERY:
            return
        pos = ctx.data.xpos[self.body_ids]
        moved = np.einsum("ij,ij->i", pos - self.rest, pos - self.rest) > MOVED_M**2
        if not moved.any():
            return
        by_task = ctx.tasks.by_task
        task = by_task[max(by_task)] if by_task else None
        for i in np.flatnonzero(moved).tolist():
            self.moved_under.setdefault(self.names[i], set()).add(task)
            self.rest[i] = pos[i]

    # -- the end ------------------------------------------------------------------------------
    def on_end(self, ctx: Context, executor: Executor, result: RunResult) -> None:
        if result.tasks is not None:
            self._task_log(ctx, result)
        self._reason(result)
        worst = {
            "joint_velocity": _num(self.worst_v),
            "joint_acceleration": _num(self.worst_a),
            "joint_acceleration_stop": _num(self.worst_a_stop),
            "joint_torque": _num(self.worst_t),
            "finger_speed_mps": _num(self.worst_f * self.finger_lim),
        }
        result.invariants = {"ok": not self.violations, "violations": self.violations,
                             "worst": worst}  # fmt: skip
        if self.from_t is not None:
            result.invariants["from_t"] = _num(self.from_t)

    def _task_log(self, ctx: Context, result: RunResult) -> None:
        held = _held(ctx)
        logged = {e["id"] for e in result.tasks or () if e.get("attempts")}
        for e in result.tasks or ():
            name = e["id"]
            if e.get("outcome") == "dropped" and name in held:
                self._end("task_log", f"{name} is logged dropped but is held between the fingers")
        if self.belt:
            return
        for name, movers in sorted(self.moved_under.items()):
            if name not in ctx.world.parcel_classes:
                continue
            strangers = sorted(str(m) for m in movers if m != name)
            if strangers:
                under = ", ".join("no task" if m == "None" else f"{m}'s task" for m in strangers)
                own = "" if name in logged else " (it has no task of its own)"
                self._end(
                    "task_log", f"{name} moved more than {MOVED_M * 100:g} cm under {under}{own}"
                )

    def _reason(self, result: RunResult) -> None:
        if result.outcome == "succeeded":
            return
        reason = result.reason or {}
        message = str(reason.get("message") or "").strip()
        state = str(reason.get("state") or "").strip()
        if not message or not state:
            missing = " and ".join(w for w, v in (("cause", message), ("state", state)) if not v)
            self._end(
                "reason",
                f"outcome {result.outcome} in {result.final_state}: its reason names no {missing}",
            )

    def _end(self, name: str, message: str) -> None:
        t = self.ctx.t
        self.violations.append({"invariant": name, "message": message, "t": _num(t),
                                "state": self.executor.leaf})  # fmt: skip


def _reader(array: np.ndarray, index: np.ndarray) -> Callable[[], list[float]]:
    """Reads `array[index]` as a list: through a view bound once when `index` is a contiguous
    run (MjData's arrays never move), else by one gather."""
    if len(index) and np.array_equal(index, np.arange(index[0], index[0] + len(index))):
        return array[int(index[0]) : int(index[0]) + len(index)].tolist
    if not len(index):
        return list
    return partial(_gather, array, index)  # a gather copies: read again at every call


def _gather(array: np.ndarray, index: np.ndarray) -> list[float]:
    return array[index].tolist()


def _held(ctx: Context) -> set[str]:
    """Objects in contact with both fingers now."""
    world, data, model = ctx.world, ctx.data, ctx.model
    finger_body = {int(g): int(model.geom_bodyid[g]) for g in world.finger_geoms}
    geom_obj = {h.geom_id: name for name, h in world.objects.items()}
    touching: dict[str, set[int]] = {}
    for i in range(data.ncon):
        c = data.contact[i]
        g1, g2 = int(c.geom1), int(c.geom2)
        for f, o in ((g1, g2), (g2, g1)):
            if f in finger_body and o in geom_obj:
                touching.setdefault(geom_obj[o], set()).add(finger_body[f])
    sides = min(2, len(set(finger_body.values())))
    return {name for name, bodies in touching.items() if len(bodies) >= sides}


def first_violation(invariants: dict[str, Any] | None) -> dict[str, Any] | None:
    """The first violation of a result's `invariants` section (None: none)."""
    if not invariants or invariants.get("ok", True):
        return None
    found = invariants.get("violations") or []
    return min(found, key=lambda v: v.get("t", math.inf)) if found else None


def violated_names(lines: list[dict[str, Any]]) -> dict[str, int]:
    """Per invariant, how many of these result lines violate it (`batch --strict`)."""
    counts: dict[str, int] = {}
    for line in lines:
        names = {
            v.get("invariant", "?") for v in (line.get("invariants") or {}).get("violations") or ()
        }
        for name in names:
            counts[name] = counts.get(name, 0) + 1
    return dict(sorted(counts.items()))
