"""One static touch of a surface with the tool, in Cartesian impedance: the measuring half of
registration by touch (`register`), run by it one touch after the other.

From wherever the controller holds the tool, the setpoint travels a route of straight segments
(jerk-limited profiles) to a point `standoff` off the face, turning the tool from the
orientation it was held at to the touch's along the first segment (a tilted face turns it by
the tilt: set in one tick, a 30-degree turn drove the wrist at ~3.6x its datasheet
acceleration); the wrist sensor is re-zeroed
there, at rest; the setpoint then moves along the face's inward normal until the normal force
shows the contact; it is then put where the spring of arm and tissue will push with the first
level's force (from where the tip is: at speed the impedance trails its setpoint by over a
millimetre) and, after the arm has settled, the force and the tool's pose are averaged; the
setpoint presses on to each further level and averages again; then it backs off to the
standoff point, reads the sensor there again (its drift since the zero, taken out of the
levels in proportion to time) and follows the retreat route.

Every position is the controller's own: forward kinematics of its pinocchio model at the
encoder readings (`impedance.measured_tcp`), never the simulator's ground truth.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from . import impedance
from .trajectory import Profile

if TYPE_CHECKING:
    from orchestrator.robots.controller import CartesianGains

    from orchestrator.engine.context import Context

__all__ = ["TouchPlan", "TouchProbe", "TouchSettings"]


@dataclass(frozen=True)
class TouchSettings:
    """How a touch is made (the `register` skill's parameters).

    Attributes:
        levels_n: Normal forces to hold, in increasing order [N].
        detect_n: Filtered normal force that tells the approach it touches [N].
        approach_speed: Speed of the setpoint towards the face [m/s].
        max_travel_m: Setpoint travel past the standoff point before `no_contact` [m].
        max_force_n: Normal force that ends the touch `overforce` [N].
        tare_s: Averaging time of the sensor's zero at the standoff point [s].
        settle_s: Time the arm is given to come to rest at each level [s].
        average_s: Averaging time at each level [s].
        speed: Speed of the route [m/s].
        accel: Acceleration of the route and of the presses [m/s^2].
        turn_speed: Angular speed of the tool's turn along the route's first segment [rad/s].
        turn_accel: Its angular acceleration [rad/s^2].
        normal_stiffness: Impedance along the face normal [N/m].
        lateral_stiffness: Impedance across it (and of the route) [N/m].
        rotational_stiffness: [Nm/rad].
        tissue_stiffness: Expected stiffness of the tissue at the levels [N/m]: how far the
            setpoint moves to go from one level to the next.
    """

    levels_n: tuple[float, ...] = (0.4, 1.2)
    detect_n: float = 0.1
    approach_speed: float = 0.01
    max_travel_m: float = 0.006
    max_force_n: float = 3.0
    tare_s: float = 0.1
    settle_s: float = 0.3
    average_s: float = 0.2
    speed: float = 0.1
    accel: float = 0.5
    turn_speed: float = 0.5
    turn_accel: float = 1.0
    normal_stiffness: float = 800.0
    lateral_stiffness: float = 3000.0
    rotational_stiffness: float = 60.0
    tissue_stiffness: float = 1000.0


@dataclass(frozen=True)
class TouchPlan:
    """Where one touch goes.

    Attributes:
        route: TCP setpoints [m] to pass through; the last is the standoff point. Shapes (3,).
        normal: Outward direction the touch is made against (the tool moves along its
            opposite), in the world. Shape (3,).
        retreat: TCP setpoints [m] to pass through after backing off. Shapes (3,).
    """

    route: Sequence[np.ndarray]
    normal: np.ndarray
    retreat: Sequence[np.ndarray] = ()


@dataclass
class TouchResult:
    """What a touch measured, per force level.

    Attributes:
        forces: Mean wrist force (external, on the tool), world frame [N]. Shapes (3,).
        sigma_f: Standard error of the mean force along the touch's normal (from the
            readings' own spread) [N].
        poses: Mean TCP position [m] and the rotation at the end of the averaging.
        times: Middle of each averaging window, from the sensor's zero [s].
        drift: The sensor's drift over the touch, taken out of `forces` (world frame) [N].
            Shape (3,).
        span_s: Time from the sensor's zero to the reading of its drift [s].
    """

    forces: list[np.ndarray] = field(default_factory=list)
    sigma_f: list[float] = field(default_factory=list)
    poses: list[tuple[np.ndarray, np.ndarray]] = field(default_factory=list)
    times: list[float] = field(default_factory=list)
    drift: np.ndarray = field(default_factory=lambda: np.zeros(3))
    span_s: float = 0.0


class TouchProbe:
    """Runs one `TouchPlan` tick by tick; `step` returns None while running, then `done`,
    `no_contact` (nothing within `max_travel_m`) or `overforce`."""

    def __init__(
        self, ctx: Context, plan: TouchPlan, settings: TouchSettings, rot: np.ndarray
    ) -> None:
        self.plan, self.cfg, self.rot = plan, settings, rot
        self.n = np.asarray(plan.normal, dtype=float) / np.linalg.norm(plan.normal)
        c = settings
        self.free: CartesianGains = impedance.gains(c.lateral_stiffness, c.rotational_stiffness)
        frame = impedance.frame_with_z(self.n)
        self.pressing: CartesianGains = impedance.gains(
            [c.lateral_stiffness, c.lateral_stiffness, c.normal_stiffness],
            c.rotational_stiffness,
            frame=frame,
        )
        self.q_null = ctx.q.copy()
        start, rot0 = impedance.setpoint(ctx, self.free)
        self.result = TouchResult()
        self.rot0 = rot0
        self.turn = _rotation_vector(rot0.T @ rot)
        """The turn from the held orientation to the touch's (body frame, rotation vector
        [rad]), made along the route's first segment. Shape (3,)."""
        self._segments(ctx, [start, *plan.route], "route")
        self.standoff = np.asarray(plan.route[-1], dtype=float)
        self.alpha = 1.0 - math.exp(-2.0 * math.pi * 30.0 * ctx.dt_control)
        self.f_filt = 0.0
        self.travel = 0.0
        self.level = 0
        self.samples: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
        self.tare: list[np.ndarray] = []
        self.outcome = "done"
        self.note = ""
        """Why the touch ended other than `done`, in words."""

    # -- the loop -----------------------------------------------------------------------
    def step(self, ctx: Context) -> str | None:
        force = ctx.wrist_force()
        f_n = float(force @ self.n)
        self.f_filt += self.alpha * (f_n - self.f_filt)
        phase = self.phase
        if phase in ("route", "retreat", "back"):
            return self._travel(ctx)
        if phase == "tare":
            return self._tare(ctx, force)
        if phase == "rezero":
            return self._rezero(ctx, force)
        if self.f_filt > self.cfg.max_force_n:
            self.note = f"{self.f_filt:.2f} N touching, above the limit {self.cfg.max_force_n:g} N"
            ctx.log("skill", f"register: {self.note}")
            self._back_off(ctx, "overforce")
            return None
        if phase == "approach":
            return self._approach(ctx)
        if phase == "press":
            return self._press(ctx)
        return self._hold(ctx, force)

    # -- phases -------------------------------------------------------------------------
    def _segments(self, ctx: Context, points: Sequence[np.ndarray], phase: str) -> None:
        self.phase = phase
        self.points = [np.asarray(p, dtype=float) for p in points]
        self.segment = 0
        self._next_segment(ctx)

    def _turning(self) -> bool:
        """Whether this segment turns the tool (the route's first, when the touch's
        orientation is not the one the tool was held at)."""
        return (
            self.phase == "route" and self.segment == 0 and float(np.linalg.norm(self.turn)) > 1e-9
        )

    def _next_segment(self, ctx: Context) -> None:
        a, b = self.points[self.segment], self.points[self.segment + 1]
        c = self.cfg
        self.profile = Profile(float(np.linalg.norm(b - a)), c.speed, c.accel)
        if self._turning():  # the slower of the move and the turn sets the pace of both
            turn = Profile(float(np.linalg.norm(self.turn)), c.turn_speed, c.turn_accel)
            self.profile = turn if turn.duration > self.profile.duration else self.profile
        self.t0 = ctx.clock

    def _travel(self, ctx: Context) -> str | None:
        a, b = self.points[self.segment], self.points[self.segment + 1]
        s, _ = self.profile.progress(ctx.clock - self.t0)
        gains = self.free if self.phase != "back" else self.pressing
        rot = self.rot0 @ _rotation(s * self.turn) if self._turning() else self.rot
        impedance.command(ctx, a + s * (b - a), rot, gains, self.q_null)
        if ctx.clock - self.t0 < self.profile.duration:
            return None
        if self.segment + 2 < len(self.points):
            self.segment += 1
            self._next_segment(ctx)
            return None
        if self.phase == "route":  # at the standoff point: settle, then zero the sensor
            self.phase, self.t0 = "tare", ctx.clock
            self.tare = []
            return None
        if self.phase == "back":  # at the standoff point again: read the sensor's drift
            self.phase, self.t0 = "rezero", ctx.clock
            self.tare = []
            return None
        return self.outcome

    def _at_standoff(self, ctx: Context, force: np.ndarray) -> np.ndarray | None:
        """Hold the standoff point: after `settle_s`, the mean reading over `tare_s` [N]
        (world frame, shape (3,)); None until then."""
        impedance.command(ctx, self.standoff, self.rot, self.pressing, self.q_null)
        elapsed = ctx.clock - self.t0
        if elapsed < self.cfg.settle_s - 1e-9:
            return None
        self.tare.append(force.copy())
        if elapsed < self.cfg.settle_s + self.cfg.tare_s - 1e-9:
            return None
        return np.mean(self.tare, axis=0)

    def _tare(self, ctx: Context, force: np.ndarray) -> str | None:
        offset = self._at_standoff(ctx, force)
        if offset is not None:
            ctx.zero_wrist_force(offset)
            self.t_zero = ctx.clock - 0.5 * self.cfg.tare_s
            self.f_filt = 0.0
            self.phase = "approach"
        return None

    def _rezero(self, ctx: Context, force: np.ndarray) -> str | None:
        """At rest in free space after the touch, the reading is the drift since the zero:
        take it out of every level, in proportion to the time elapsed (a linear bridge)."""
        drift = self._at_standoff(ctx, force)
        if drift is None:
            return None
        span = ctx.clock - self.t_zero
        r = self.result
        r.forces = [
            f - (t - self.t_zero) / span * drift for f, t in zip(r.forces, r.times, strict=True)
        ]
        r.times = [t - self.t_zero for t in r.times]
        r.drift, r.span_s = drift, span
        if self.outcome == "done" and len(self.plan.retreat):
            self._segments(ctx, [self.standoff, *self.plan.retreat], "retreat")
            return None
        return self.outcome

    def _approach(self, ctx: Context) -> str | None:
        c = self.cfg
        if self.f_filt >= c.detect_n:
            self._press_to(ctx, c.levels_n[0], self.f_filt)
            return None
        if self.travel >= c.max_travel_m:
            self.note = f"no contact within {c.max_travel_m * 1000:.1f} mm of the standoff point"
            ctx.log("skill", f"register: {self.note}")
            self._back_off(ctx, "no_contact")
            return None
        self.travel += c.approach_speed * ctx.dt_control * ctx.clock_rate
        self._command(ctx)
        return None

    def _settle(self, ctx: Context) -> None:
        self.phase, self.t0 = "hold", ctx.clock
        self.samples = []

    def _hold(self, ctx: Context, force: np.ndarray) -> str | None:
        self._command(ctx)
        elapsed = ctx.clock - self.t0
        if elapsed < self.cfg.settle_s - 1e-9:
            return None
        pos, rot = impedance.measured_tcp(ctx)
        self.samples.append((force.copy(), pos, rot))
        if elapsed < self.cfg.settle_s + self.cfg.average_s - 1e-9:
            return None
        forces = np.array([s[0] for s in self.samples])
        normal = forces @ self.n
        r = self.result
        r.forces.append(forces.mean(axis=0))
        r.sigma_f.append(float(normal.std(ddof=1) / math.sqrt(len(normal))))
        r.poses.append((np.mean([s[1] for s in self.samples], axis=0), self.samples[-1][2]))
        r.times.append(ctx.clock - 0.5 * self.cfg.average_s)
        self.level += 1
        if self.level >= len(self.cfg.levels_n):
            self._back_off(ctx, "done")
            return None
        self._press_to(ctx, self.cfg.levels_n[self.level], float(normal.mean()))
        return None

    def _press_to(self, ctx: Context, level_n: float, now_n: float) -> None:
        """Move the setpoint to where the arm at rest pushes with `level_n` [N], the tip
        pushing with `now_n` [N] where it is now: the tip goes (level - now) / k_tissue
        deeper and the impedance spring holds level / k_normal."""
        c = self.cfg
        tip, _ = impedance.measured_tcp(ctx)
        tip_travel = float(self.n @ (self.standoff - tip))
        target = tip_travel + (level_n - now_n) / c.tissue_stiffness + level_n / c.normal_stiffness
        self.press_from, self.press_to = self.travel, target
        self.press = Profile(abs(target - self.travel), self.cfg.approach_speed, self.cfg.accel)
        self.phase, self.t0 = "press", ctx.clock

    def _press(self, ctx: Context) -> str | None:
        s, _ = self.press.progress(ctx.clock - self.t0)
        self.travel = self.press_from + s * (self.press_to - self.press_from)
        self._command(ctx)
        if ctx.clock - self.t0 >= self.press.duration:
            self._settle(ctx)
        return None

    def _back_off(self, ctx: Context, outcome: str) -> None:
        self.outcome = outcome
        start, _ = impedance.setpoint(ctx)
        self._segments(ctx, [start, self.standoff], "back")

    def _command(self, ctx: Context) -> None:
        pos = self.standoff - self.travel * self.n
        impedance.command(ctx, pos, self.rot, self.pressing, self.q_null)


def _rotation(v: np.ndarray) -> np.ndarray:
    """The rotation matrix of the rotation vector `v` [rad] (Rodrigues). Shape (3, 3)."""
    angle = float(np.linalg.norm(v))
    if angle < 1e-12:
        return np.eye(3)
    k = v / angle
    skew = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) + math.sin(angle) * skew + (1.0 - math.cos(angle)) * skew @ skew


def _rotation_vector(rot: np.ndarray) -> np.ndarray:
    """The rotation vector [rad] of the rotation matrix `rot` (shape (3, 3)), its angle in
    [0, pi). Shape (3,)."""
    c = max(-1.0, min(1.0, (float(np.trace(rot)) - 1.0) / 2.0))
    angle = math.acos(c)
    w = np.array([rot[2, 1] - rot[1, 2], rot[0, 2] - rot[2, 0], rot[1, 0] - rot[0, 1]])
    if angle < 1e-9:
        return 0.5 * w  # sin(angle) ~ angle
    return angle / (2.0 * math.sin(angle)) * w
