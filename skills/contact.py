"""`contact`: approach a surface in Cartesian impedance, then hold a normal force (and trace).

The tool tip moves along `axis` (any direction; by default into the surface of `frame`, along
its registered normal) at `approach_speed` under an impedance compliant along the axis and
stiff across it, in the surface's own frame, until the filtered wrist force along the axis
reaches `target_force_n` (`contacted`); meanwhile the tool turns to point along the axis and
the tip moves onto the approach line. Then an explicit force loop regulates that force: it
integrates the force error into how far the impedance setpoint sits below the surface, with a
gain scheduled on the expected stiffness of the contact (the arm's impedance in series with
the surface). Meanwhile the setpoint can follow a path laterally (`done` at its end), and an
integral term removes the tip's steady cross-track error (joint and tissue friction against
the lateral impedance), measured by the controller's own model at the encoder readings. The
arm is never position-stiff along the axis, so running into a surface costs the force of the
impedance spring, not a collision.

Force sensing: the wrist reading is the sensor's zeroed output (optionally re-zeroed here in
free space, `tare_s`) low-pass filtered at `filter_hz`.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import TYPE_CHECKING, Annotated, Any, ClassVar

import numpy as np
from pydantic import Field, NonNegativeFloat, PositiveFloat, field_validator, model_validator

from orchestrator.exceptions import SkillError
from orchestrator.world.path import PlannedPath, TraceSpec
from orchestrator.world.pose import Pose

from . import impedance
from .base import Skill, SkillParams
from .trajectory import Profile

if TYPE_CHECKING:
    from orchestrator.engine.context import Context

__all__ = ["Contact", "ContactParams"]

Vec3 = Annotated[list[float], Field(min_length=3, max_length=3)]


class ContactParams(SkillParams):
    axis: Vec3 | None = Field(
        default=None,
        description="Approach direction in the world (any); default: into the surface of "
        "`frame` (its -z), else straight down [0, 0, -1].",
    )
    target_force_n: PositiveFloat = Field(
        default=2.0, le=50.0, description="Normal force to reach and hold [N]."
    )
    max_force_n: PositiveFloat = Field(
        default=10.0,
        le=100.0,
        description="Filtered force, normal or in total (a lateral load counts), that ends the"
        " skill `overforce` [N].",
    )
    approach_speed: PositiveFloat = Field(default=0.01, le=0.05, description="[m/s]")
    max_travel_m: PositiveFloat = Field(
        default=0.05, le=0.3, description="Setpoint travel along the axis before `no_contact` [m]."
    )
    frame: Any = Field(
        default=None,
        description="Pose (`{pos, quat}`, e.g. `$phantom_pose`) that `at` and `path` are given "
        "in; default: the world.",
    )
    at: Vec3 | None = Field(
        default=None,
        description="Point the approach line passes through, in `frame` [m]; default: the first "
        "waypoint, else where the tip is.",
    )
    path: list[Vec3] = Field(
        default_factory=list,
        description="Waypoints traced at the target force, in `frame` [m]; only their lateral "
        "position counts (the force sets the depth).",
    )
    speed: PositiveFloat = Field(default=0.01, le=0.1, description="Tracing speed [m/s].")
    accel: PositiveFloat = Field(default=0.05, le=1.0, description="Tracing acceleration [m/s^2].")
    hold_s: NonNegativeFloat = Field(
        default=0.0, description="Time at the target force before tracing (or alone) [s]."
    )
    tolerance_m: PositiveFloat = Field(
        default=0.0005, description="Lateral distance to the last waypoint that ends the trace [m]."
    )
    filter_hz: PositiveFloat = Field(
        default=15.0, le=200.0, description="Cut-off of the force low-pass filter [Hz]."
    )
    tare_s: NonNegativeFloat = Field(
        default=0.0,
        description="Re-zero the wrist sensor over this long before approaching, in free "
        "space [s] (0: keep the sensor's zero).",
    )
    surface_stiffness_n_per_m: PositiveFloat | None = Field(
        default=None, description="Expected stiffness of the surface [N/m]; default: rigid."
    )
    force_time_constant_s: PositiveFloat = Field(
        default=0.15, ge=0.02, description="Time constant of the force loop [s]."
    )
    stiffness_n_per_m: PositiveFloat = Field(
        default=800.0, le=5000.0, description="Impedance along the axis [N/m]."
    )
    lateral_stiffness_n_per_m: PositiveFloat = Field(
        default=3000.0, le=10000.0, description="Impedance across the axis [N/m]."
    )
    rotational_stiffness: PositiveFloat = Field(
        default=60.0, le=500.0, description="Rotational impedance [Nm/rad]."
    )
    align: bool = Field(
        default=True,
        description="Turn the tool to point along the axis while approaching (its tip then "
        "touches with the point its TCP names).",
    )
    lateral_gain: NonNegativeFloat = Field(
        default=10.0,
        le=50.0,
        description="Integral gain on the tip's cross-track error while in contact [1/s] "
        "(0: none).",
    )
    max_correction_m: PositiveFloat = Field(
        default=0.0005, le=0.005, description="Largest cross-track correction [m]."
    )

    @field_validator("axis")
    @classmethod
    def _nonzero(cls, v: list[float] | None) -> list[float] | None:
        if v is not None and float(np.linalg.norm(np.asarray(v, dtype=float))) < 1e-9:
            raise ValueError(f"axis {v} has no direction (e.g. [0, 0, -1])")
        return v

    @model_validator(mode="after")
    def _limits(self) -> ContactParams:
        if self.max_force_n <= self.target_force_n:
            raise ValueError(
                f"max_force_n {self.max_force_n} must exceed target_force_n {self.target_force_n}"
            )
        if len(self.path) == 1:
            raise ValueError("a path needs at least 2 waypoints (or none)")
        return self


class Contact(Skill):
    """Approach along an axis until the force reaches a target, then hold it (and trace).

    Outcomes: `contacted` (the force reached the target; returned at once when there is no
    path and no `hold_s`), `done` (held for `hold_s` and traced the path), `no_contact` (the
    travel limit came first, or contact was lost), `overforce` (the filtered force passed
    `max_force_n`; the spring preload is released).

    Metrics of a trace (from the start of the lateral motion): `force_rms_error_n` and
    `peak_force_n` of the unfiltered force, `path_deviation_rms_mm` and `path_deviation_max_mm`
    of the tip's lateral distance to the planned path (the path as registered, per control
    tick: the run's `true_cross_track_*` measure it against the true one, every physics step),
    `cross_track_correction_mm` (the integral term's largest correction).
    """

    name: ClassVar[str] = "contact"
    Params: ClassVar[type[SkillParams]] = ContactParams
    outcomes: ClassVar[tuple[str, ...]] = ("contacted", "done", "no_contact", "overforce")

    params: ContactParams

    def start(self, ctx: Context) -> None:
        p = self.params
        frame, self.frame_pose = _frame(p.frame)
        if p.axis is not None:
            axis = np.asarray(p.axis, dtype=float)
        elif self.frame_pose is not None:
            axis = -self.frame_pose[1][:, 2]  # into the surface
        else:
            axis = np.array([0.0, 0.0, -1.0])
        self.n = axis / np.linalg.norm(axis)
        """Unit approach direction in the world (into the surface). Shape (3,)."""
        k_n = p.stiffness_n_per_m
        k_lat = p.lateral_stiffness_n_per_m
        self.gains = impedance.gains(
            [k_lat, k_lat, k_n], p.rotational_stiffness, frame=impedance.frame_with_z(self.n)
        )
        pos, rot0 = impedance.setpoint(ctx, self.gains)
        self.rot0 = rot0
        self.turn = _rotation_vector(impedance.aligned(rot0, self.n) @ rot0.T) if p.align else None
        """World-frame rotation vector [rad] from the start orientation to the aligned one."""
        self.turn_profile = Profile(
            float(np.linalg.norm(self.turn)) if self.turn is not None else 0.0, 0.3, 1.0
        )
        self.rot = rot0.copy()
        self.planned = PlannedPath(np.array([frame(w) for w in p.path]), self.n) if p.path else None
        """The path in the world, projected on the plane perpendicular to the axis."""
        if p.at is not None:
            anchor = frame(p.at)
        else:
            anchor = self.planned.points[0] if self.planned is not None else pos
        self.lead_from = self._lateral(pos)
        self.lead_to = self._lateral(anchor)
        self.lead = Profile(
            float(np.linalg.norm(self.lead_to - self.lead_from)), p.approach_speed, 0.05
        )
        """The setpoint's way from where it is onto the approach line, across the axis."""
        self.lateral = self.lead_from.copy()
        """The setpoint across the axis [m]: where the approach line passes. Shape (3,)."""
        self.correction = np.zeros(3)
        """The integral term's cross-track correction of the setpoint [m]. Shape (3,)."""
        self.max_correction = 0.0
        self.depth0 = float(pos @ self.n)
        """Normal coordinate of the setpoint at start [m]; `s` is measured from it."""
        self.s = 0.0
        k_s = p.surface_stiffness_n_per_m
        k_contact = k_n if k_s is None else k_n * k_s / (k_n + k_s)
        self.k_i = 1.0 / (k_contact * p.force_time_constant_s)
        """Force-loop gain: setpoint speed per newton of error [m/(N s)]."""
        self.alpha = 1.0 - math.exp(-2.0 * math.pi * p.filter_hz * ctx.dt_control)
        self.q_null = ctx.q.copy()
        self.f_filt = self._normal(ctx.wrist_force())
        self.f_total_filt = float(np.linalg.norm(ctx.wrist_force()))
        """Low-passed norm of the whole wrist force [N]: the lateral load counts too."""
        self.t0 = ctx.clock
        self.phase = "tare" if p.tare_s > 0.0 else "approach"
        self.tare: list[np.ndarray] = []
        self.t_force: float | None = None
        self.profile: Profile | None = None
        self.t_trace = 0.0
        self.trace: list[tuple[float, float, float]] = []
        """(normal force error [N], force norm [N], lateral deviation [m]) per tick."""
        self.reported = False
        self._command(ctx)

    # -- the loop -----------------------------------------------------------------------
    def step(self, ctx: Context) -> str | None:
        p = self.params
        force = ctx.wrist_force()
        f_n = self._normal(force)
        self.f_filt += self.alpha * (f_n - self.f_filt)
        self.f_total_filt += self.alpha * (math.sqrt(float(force @ force)) - self.f_total_filt)
        if self.phase == "tare":
            return self._tare(ctx, force)
        if self.f_filt > p.max_force_n or self.f_total_filt > p.max_force_n:
            ctx.log(
                "skill",
                f"contact: {self.f_total_filt:.2f} N ({self.f_filt:.2f} N normal) exceeds"
                f" {p.max_force_n} N",
            )
            tip, _ = impedance.measured_tcp(ctx)
            self.s = float(tip @ self.n) - self.depth0  # release the spring preload
            self._command(ctx)
            return "overforce"
        if self.phase == "approach":
            return self._approach(ctx)
        return self._hold_and_trace(ctx, force, f_n)

    def stop(self, ctx: Context) -> None:
        # The impedance setpoint stays (a compliant hold, keeping any contact preload for the
        # next skill); the controller's q_d follows the arm meanwhile.
        ctx.planned_path = None
        ctx.trace = None
        self._report(ctx)

    # -- phases -------------------------------------------------------------------------
    def _tare(self, ctx: Context, force: np.ndarray) -> str | None:
        self.tare.append(force.copy())
        if ctx.clock - self.t0 < self.params.tare_s - 1e-9:
            return None
        offset = np.mean(self.tare, axis=0)
        ctx.zero_wrist_force(offset)
        ctx.log("skill", f"contact: wrist sensor re-zeroed ({np.linalg.norm(offset):.3f} N)")
        self.f_filt = self._normal(ctx.wrist_force())
        self.f_total_filt = float(np.linalg.norm(ctx.wrist_force()))
        self.phase = "approach"
        return None

    def _approach(self, ctx: Context) -> str | None:
        p = self.params
        if self.f_filt >= p.target_force_n:
            ctx.log("skill", f"contact: {self.f_filt:.2f} N after {self.s * 1000:.1f} mm")
            self.lateral = self.lead_to.copy()
            if self.turn is not None:
                self.rot = _exp(self.turn) @ self.rot0
            if self.planned is None and p.hold_s <= 0.0:
                return "contacted"
            self.phase = "force"
            self.t_force = ctx.clock
            ctx.planned_path = self.planned
            return None
        if self.s >= p.max_travel_m:
            ctx.log("skill", f"contact: no contact within {p.max_travel_m * 1000:.0f} mm")
            return "no_contact"
        self.s = min(self.s + p.approach_speed * ctx.dt_control * ctx.clock_rate, p.max_travel_m)
        elapsed = ctx.clock - self.t0 - (p.tare_s if p.tare_s > 0.0 else 0.0)
        frac, _ = self.lead.progress(elapsed)
        self.lateral = self.lead_from + frac * (self.lead_to - self.lead_from)
        if self.turn is not None:
            frac, _ = self.turn_profile.progress(elapsed)
            self.rot = _exp(frac * self.turn) @ self.rot0
        self._command(ctx)
        return None

    def _hold_and_trace(self, ctx: Context, force: np.ndarray, f_n: float) -> str | None:
        p = self.params
        assert self.t_force is not None
        self.s += self.k_i * (p.target_force_n - self.f_filt) * ctx.dt_control * ctx.clock_rate
        if self.s >= p.max_travel_m:
            ctx.log("skill", "contact: lost contact (travel limit reached)")
            return "no_contact"
        held = ctx.clock - self.t_force
        if self.planned is not None and ctx.trace is None:
            # the tip is in the tissue from here: the ground truth (engine/trace_truth.py)
            # measures the dwell at the start point too, not only the lateral motion
            ctx.trace = TraceSpec(
                np.asarray(p.path, dtype=float),
                self.frame_pose,
                self.n,
                p.target_force_n,
                self.lateral.copy(),
            )
        if held < p.hold_s - 1e-9:
            if ctx.trace is not None:
                ctx.trace.reference[:] = self.lateral
            if self.planned is not None:
                self._correct(ctx, 0.0)
            self._command(ctx)
            return None
        if self.planned is None:
            return "done"
        if self.profile is None:
            self.profile = Profile(self.planned.length, p.speed, p.accel)
            self.t_trace = ctx.clock
        elapsed = ctx.clock - self.t_trace
        fraction, _ = self.profile.progress(elapsed)
        self.lateral = self.planned.point_at(fraction * self.planned.length)
        if ctx.trace is not None:
            ctx.trace.reference[:] = self.lateral
        self._correct(ctx, fraction * self.planned.length)
        self._command(ctx)
        dev = self.planned.deviation(ctx.tcp_pos)
        self.trace.append((p.target_force_n - f_n, math.sqrt(float(force @ force)), dev))
        if elapsed < self.profile.duration:
            return None
        end = self._lateral(self.planned.points[-1])
        tip, _ = impedance.measured_tcp(ctx)
        if float(np.linalg.norm(self._lateral(tip) - end)) <= p.tolerance_m:
            self._report(ctx)
            return "done"
        return None

    # -- helpers ------------------------------------------------------------------------
    def _normal(self, force: np.ndarray) -> float:
        """The part of a wrist force (shape (3,)) pushing back against the approach [N]."""
        return -float(force @ self.n)

    def _lateral(self, point: np.ndarray) -> np.ndarray:
        """`point` (shape (3,)) projected on the plane perpendicular to the axis."""
        return point - float(point @ self.n) * self.n

    def _correct(self, ctx: Context, distance: float) -> None:
        """Integrate the tip's cross-track error at `distance` [m] along the path into the
        setpoint's correction. The tip is where the controller's model puts it (encoders)."""
        p = self.params
        if p.lateral_gain <= 0.0:
            return
        assert self.planned is not None
        side = np.cross(self.n, self.planned.direction_at(distance))
        tip, _ = impedance.measured_tcp(ctx)
        error = float((self.lateral - tip) @ side)
        self.correction += p.lateral_gain * error * ctx.dt_control * ctx.clock_rate * side
        norm = float(np.linalg.norm(self.correction))
        if norm > p.max_correction_m:
            self.correction *= p.max_correction_m / norm
        self.max_correction = max(self.max_correction, min(norm, p.max_correction_m))

    def _command(self, ctx: Context) -> None:
        pos = self.lateral + self.correction + (self.depth0 + self.s) * self.n
        impedance.command(ctx, pos, self.rot, self.gains, self.q_null)

    def _report(self, ctx: Context) -> None:
        if self.reported or not self.trace:
            return
        self.reported = True
        err, norm, dev = (np.array(c) for c in zip(*self.trace, strict=True))
        ctx.metrics.update(
            {
                "force_rms_error_n": round(float(np.sqrt(np.mean(err**2))), 4),
                "peak_force_n": round(float(norm.max()), 4),
                "path_deviation_rms_mm": round(float(np.sqrt(np.mean(dev**2))) * 1000, 4),
                "path_deviation_max_mm": round(float(dev.max()) * 1000, 4),
                "cross_track_correction_mm": round(self.max_correction * 1000, 4),
            }
        )


def _rotation_vector(rot: np.ndarray) -> np.ndarray:
    """Rotation vector [rad] of a rotation matrix (shape (3, 3)). Shape (3,)."""
    import mujoco

    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, np.ascontiguousarray(rot).reshape(9))
    vec = np.zeros(3)
    mujoco.mju_quat2Vel(vec, quat, 1.0)
    return vec


def _exp(vec: np.ndarray) -> np.ndarray:
    """Rotation matrix of a rotation vector [rad] (shape (3,)). Shape (3, 3)."""
    import mujoco

    angle = float(np.linalg.norm(vec))
    quat = np.array([1.0, 0.0, 0.0, 0.0])
    if angle > 0.0:
        mujoco.mju_axisAngle2Quat(quat, vec / angle, angle)
    rot = np.zeros(9)
    mujoco.mju_quat2Mat(rot, quat)
    return rot.reshape(3, 3)


def _frame(
    value: Any,
) -> tuple[Callable[[Any], np.ndarray], tuple[np.ndarray, np.ndarray] | None]:
    """A function mapping points [m] in the pose `value` (or the world if None) to the world,
    and the pose as (position [m] shape (3,), rotation shape (3, 3)) or None."""
    import mujoco

    if value is None:
        return (lambda p: np.asarray(p, dtype=float)), None
    try:
        pose = Pose.coerce(value)
    except (TypeError, ValueError) as exc:
        raise SkillError(f"contact: cannot read a frame from {value!r}: {exc}") from None
    quat = np.asarray(pose.quat, dtype=float)
    rot = np.zeros(9)
    mujoco.mju_quat2Mat(rot, quat / np.linalg.norm(quat))
    rot = rot.reshape(3, 3)
    origin = np.asarray(pose.pos, dtype=float)
    return (lambda p: rot @ np.asarray(p, dtype=float) + origin), (origin, rot)
