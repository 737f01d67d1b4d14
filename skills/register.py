"""`register`: locate the phantom — by its fiducials (a camera), then, optionally, by touch.

`method: fiducials` fits the pose of the phantom's top surface (position and orientation) to
its four fiducials as perception sees them: fast, and as good as the camera (0.1-0.2 mm at the
bundled 0.5 mm noise). `method: touch` starts from that estimate (or from `prior`) and touches
the phantom with the probe's ball tip: three points on its top, two on the edge it makes with
its long side, one on its edge with an end (a 3-2-1 scheme that fixes all six degrees of
freedom), each held still at two force levels (`skills/touch_probe.py`). The tissue yields
under the tip, so the surface is not where the tip stopped: the pose (position and
orientation, any tilt) and one unknown scale of the registered force law (the true stiffness)
are fitted to every level of every touch at once, with their covariance
(`skills/touch_fit.py`). What it measures is the controller's own: forward kinematics of its
model at the encoder readings.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Annotated, Any, ClassVar, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, NonNegativeFloat, PositiveFloat, PositiveInt

from orchestrator.world.pose import Pose, rotation_of, yaw_of
from orchestrator.world.tissue import TissueLaw

from . import impedance
from .base import Skill, SkillParams
from .touch_fit import Touch, TouchFit, fit_touches, lateral_sigma
from .touch_probe import TouchPlan, TouchProbe, TouchSettings

if TYPE_CHECKING:
    from orchestrator.robots.tool import Tool

    from orchestrator.engine.context import Context

__all__ = ["Register", "RegisterParams", "TouchPoint"]

Vec3 = Annotated[list[float], Field(min_length=3, max_length=3)]

FACES: dict[str, tuple[float, float, float]] = {
    "top": (0.0, 0.0, 1.0),
    "-x": (-1.0, 0.0, 0.0),
    "+x": (1.0, 0.0, 0.0),
    "-y": (0.0, -1.0, 0.0),
    "+y": (0.0, 1.0, 0.0),
}
"""Outward normals of the phantom's top and side faces, in its surface frame."""


class TouchPoint(BaseModel):
    """A point to touch with the ball tip: on the top face, or on the edge the top makes with
    a side face (`-y`: the side at y = -size/2), and where, in the phantom's surface frame [m]
    (a point of that face or edge)."""

    model_config = ConfigDict(defer_build=True, extra="forbid", allow_inf_nan=False)

    on: Literal["top", "-x", "+x", "-y", "+y"]
    at: Vec3


class RegisterParams(SkillParams):
    object: str = Field(default="phantom", description="The phantom to register, by name.")
    into: str = Field(
        default="phantom_pose",
        description="Blackboard key the registered pose of its top-surface centre goes to.",
    )
    stiffness_into: str = Field(
        default="phantom_stiffness",
        description="Blackboard key its registered stiffness [N/m] goes to (see `at_force_n`).",
    )
    method: Literal["fiducials", "touch"] = Field(
        default="fiducials",
        description="`fiducials`: the camera alone; `touch`: then touch it with the tool.",
    )
    prior: Any = Field(
        default=None,
        description="Pose (`$phantom_pose`) the touches start from; default: the fiducials'.",
    )
    at_force_n: PositiveFloat | None = Field(
        default=None,
        le=50.0,
        description="Report the stiffness the tissue has under this force (the tangent "
        "stiffness at a contact's working point) [N]; default: at the surface.",
    )
    tolerance_m: PositiveFloat = Field(
        default=0.002, description="Largest fiducial registration error (RMS) accepted [m]."
    )
    max_offset_m: PositiveFloat = Field(
        default=0.03, description="Farthest the phantom may be from its planned place [m]."
    )
    samples: PositiveInt = Field(default=5, le=100, description="Measurements per fiducial.")
    inset_m: NonNegativeFloat = Field(
        default=0.01, description="Fiducials sit this far inside the top surface's corners [m]."
    )
    duration_s: NonNegativeFloat = Field(default=0.2, description="Time the search takes [s].")
    touches: list[TouchPoint] | None = Field(
        default=None,
        min_length=6,
        description="Where to touch; default: 3 on the top, 2 on its edge with the -y side, 1 "
        "on its edge with the -x end.",
    )
    levels_n: list[PositiveFloat] = Field(
        default_factory=lambda: [0.4, 1.2],
        min_length=2,
        max_length=4,
        description="Normal forces each touch holds still at, increasing [N].",
    )
    standoff_m: PositiveFloat = Field(
        default=0.002, le=0.02, description="Gap to the face the approach starts from [m]."
    )
    clearance_m: PositiveFloat = Field(
        default=0.01, le=0.1, description="Height above the top the tool moves between [m]."
    )
    max_sigma_m: PositiveFloat = Field(
        default=5e-5,
        description="Largest 1-sigma lateral error of the touched pose on the top surface [m].",
    )
    max_tilt_deg: PositiveFloat = Field(
        default=10.0,
        le=90.0,
        description="Steepest tilt of the top (the fiducials' estimate) touched [deg]; steeper "
        "is `out_of_tolerance` before the tool moves. The default 3-2-1 touches are qualified "
        "to 10: tilted 8.5 deg the surgical phantom registered and was traced, at 18.4 the "
        "touched pose came out uncertain by 0.3 mm (bar 0.05 mm), at 28.4 the first touch met "
        "nothing.",
    )


class Register(Skill):
    """Register the phantom (see the module docstring for the two methods).

    Outcomes: `registered` (within every tolerance; the pose goes to `into`, the stiffness
    to `stiffness_into`), `not_found` (no such phantom, a fiducial unseen, a touch that met
    nothing), `out_of_tolerance` (fiducial error above `tolerance_m`, the pose farther than
    `max_offset_m` from the plan, a touch above its force limit, touches that leave the pose
    undetermined, or the touched pose's uncertainty above `max_sigma_m`). Metrics:
    `registration_fre_mm`, `registration_offset_mm` and, by touch, `registration_sigma_mm`
    (1-sigma lateral error on the top surface, worst corner), `registration_sigma_deg`,
    `registration_law_rms_n`, `registration_stiffness_scale`, `registration_touch_s`.
    """

    name: ClassVar[str] = "register"
    Params: ClassVar[type[SkillParams]] = RegisterParams
    outcomes: ClassVar[tuple[str, ...]] = ("registered", "not_found", "out_of_tolerance")
    writes: ClassVar[dict[str, str]] = {"into": "pose", "stiffness_into": "float"}

    params: RegisterParams

    def start(self, ctx: Context) -> None:
        self.t0 = ctx.clock
        self.why = ""
        self.probes: list[TouchProbe] = []
        self.probe: TouchProbe | None = None
        self.pose: tuple[np.ndarray, np.ndarray] | None = None
        if self.params.prior is not None:
            prior = Pose.coerce(self.params.prior)
            self.pose = (np.asarray(prior.pos, dtype=float), rotation_of(prior.quat))

    def step(self, ctx: Context) -> str | None:
        p = self.params
        if self.probe is not None:
            return self._touching(ctx)
        if self.pose is None and ctx.clock - self.t0 < p.duration_s - 1e-9:
            return None
        phantom = ctx.world.phantom
        if phantom is None or phantom.name != p.object:
            self._error(ctx, f"no phantom {p.object!r} in the scene")
            return "not_found"
        if self.pose is None:
            outcome = self._fiducials(ctx)
            if outcome is not None:
                return outcome
        if p.method == "fiducials":
            assert self.pose is not None
            return self._write(ctx, *self.pose, scale=1.0)
        tool: Tool | None = getattr(ctx.robot, "tool", None)
        if tool is None:
            self._error(ctx, "touching needs a tool on the flange")
            return "not_found"
        assert self.pose is not None
        tilt = math.degrees(math.acos(min(1.0, abs(float(self.pose[1][2, 2])))))
        if tilt > p.max_tilt_deg:
            self._error(
                ctx,
                f"{p.object!r} is tilted {tilt:.1f} deg (the fiducials): touching is qualified "
                f"to {p.max_tilt_deg:g} deg (max_tilt_deg)",
            )
            return "out_of_tolerance"
        self.tool = tool
        return self._plan(ctx)

    def stop(self, ctx: Context) -> None:
        """Keep the compliant hold where the touches left the tool."""

    def explain(self, ctx: Context) -> str | None:
        return self.why or None

    def _error(self, ctx: Context, text: str) -> None:
        """Say why registration failed (the log and the transition's detail)."""
        self.why = text
        ctx.log("skill", f"register: {text}", level="ERROR")

    # -- fiducials ----------------------------------------------------------------------
    def _fiducials(self, ctx: Context) -> str | None:
        p = self.params
        phantom = ctx.world.phantom
        assert phantom is not None
        hx, hy = phantom.size[0] / 2 - p.inset_m, phantom.size[1] / 2 - p.inset_m
        model_pts = np.array([[hx, hy, 0.0], [-hx, hy, 0.0], [-hx, -hy, 0.0], [hx, -hy, 0.0]])
        truth = model_pts @ phantom.rotation.T + phantom.surface_pos
        sigma = ctx.scenario.perception.position_noise_m
        noise = ctx.rng.normal(0.0, sigma, (p.samples, *truth.shape))
        seen = [ctx.perceived(Pose(pos=pt.tolist())) for pt in truth + noise.mean(axis=0)]
        if any(s is None for s in seen):
            self._error(ctx, f"a fiducial of {p.object!r} was not found")
            return "not_found"
        measured = np.array([s.pos for s in seen if s is not None])
        rot, pos = _kabsch(model_pts, measured)
        fre = float(np.sqrt(np.mean(np.sum((model_pts @ rot.T + pos - measured) ** 2, 1))))
        ctx.metrics["registration_fre_mm"] = round(fre * 1000, 4)
        if fre > p.tolerance_m:
            self._error(
                ctx,
                f"{p.object!r} fiducial error {fre * 1000:.2f} mm (limit "
                f"{p.tolerance_m * 1000:.2f})",
            )
            return "out_of_tolerance"
        self.pose = (pos, rot)
        if not self._near_plan(ctx, pos):
            return "out_of_tolerance"
        ctx.log(
            "skill",
            f"register: fiducials put {p.object!r} at {np.round(pos, 4).tolist()}, yaw "
            f"{math.degrees(yaw_of(_quat(rot))):.2f} deg, FRE {fre * 1000:.3f} mm",
        )
        return None

    # -- touch --------------------------------------------------------------------------
    def _plan(self, ctx: Context) -> str | None:
        """The touches, in the prior estimate, and the first probe under way; `out_of_tolerance`
        if a touch lies beyond the arm's reach (explore: on a phantom 1.6 m long the arm was
        pulled towards its far end, joint 2 at 8x its datasheet acceleration)."""
        p = self.params
        assert self.pose is not None and ctx.world.phantom is not None
        self.points = p.touches or _default_touches(ctx.world.phantom.size)
        t0, r0 = self.pose
        self.top = r0[:, 2]
        _, rot = impedance.setpoint(ctx)
        self.rot = impedance.aligned(rot, -self.top)
        """Tool orientation for every touch: its axis along the prior's inward top normal."""
        self.t_touch = ctx.clock
        self.plans = [self._touch_plan(tp, t0, r0) for tp in self.points]
        shoulder = ctx.robot.shoulder(ctx.q, np.asarray(ctx.scenario.robot.base_pos, float))
        for i, plan in enumerate(self.plans):
            far = max(float(np.linalg.norm(np.asarray(pt) - shoulder)) for pt in plan.route)
            if far > ctx.robot.reach_m:
                tp = self.points[i]
                self._error(
                    ctx,
                    f"touch {i + 1} ({tp.on} at {np.round(tp.at, 4).tolist()}) is "
                    f"{far:.3f} m from the shoulder, beyond the arm's reach "
                    f"({ctx.robot.reach_m:g} m)",
                )
                return "out_of_tolerance"
        self._next_probe(ctx)
        return None

    def _touch_plan(self, tp: TouchPoint, t0: np.ndarray, r0: np.ndarray) -> TouchPlan:
        """Ball centre `standoff_m` off the feature along the touch's outward direction (the
        top's normal; on an edge, the bisector of the top's and the side's), reached from
        `clearance_m` above the top and left the same way."""
        p, tool = self.params, self.tool
        out = r0 @ _outward(tp.on)
        at = r0 @ np.asarray(tp.at, dtype=float) + t0
        centre = at + (tool.tip_radius_m + p.standoff_m) * out
        tcp = centre - tool.tip_radius_m * self.top  # the tool points along -top
        above = tcp + (float(self.top @ (t0 - tcp)) + p.clearance_m) * self.top
        return TouchPlan(route=[above, tcp], normal=out, retreat=[above])

    def _next_probe(self, ctx: Context) -> None:
        plan = self.plans[len(self.probes)]
        settings = TouchSettings(
            levels_n=tuple(self.params.levels_n), max_travel_m=self.params.standoff_m + 0.004
        )
        self.probe = TouchProbe(ctx, plan, settings, self.rot)
        self.probes.append(self.probe)

    def _touching(self, ctx: Context) -> str | None:
        assert self.probe is not None
        outcome = self.probe.step(ctx)
        if outcome is None:
            return None
        if outcome != "done":
            tp = self.points[len(self.probes) - 1]
            self._error(
                ctx,
                f"touch {len(self.probes)} ({tp.on} at {np.round(tp.at, 4).tolist()}) ended "
                f"{outcome}: {self.probe.note}",
            )
            return "not_found" if outcome == "no_contact" else "out_of_tolerance"
        if len(self.probes) < len(self.plans):
            self._next_probe(ctx)
            return None
        return self._fit(ctx)

    def _fit(self, ctx: Context) -> str:
        p = self.params
        assert self.pose is not None and ctx.world.phantom is not None
        spec = ctx.scenario.scene.phantom
        assert spec is not None
        radius = self.tool.tip_radius_m
        results = [pr.result for pr in self.probes]
        # The drift taken out of each level is a straight line between two zero readings;
        # the sensor's random walk strays from it by rate^2 t (T - t) / T, the rate (per
        # axis) estimated from every touch's drift over its span.
        rate_sq = float(np.mean([r.drift @ r.drift / (3.0 * r.span_s) for r in results]))
        touches = [
            Touch(
                centres=np.array([pos - radius * rot[:, 2] for pos, rot in r.poses]),
                forces=np.array(r.forces),
                sigma_n=np.sqrt(
                    np.square(np.maximum(r.sigma_f, 1e-4))
                    + rate_sq * np.array([t * (r.span_s - t) / r.span_s for t in r.times])
                ),
            )
            for r in results
        ]
        size = ctx.world.phantom.size
        t, rot = self.pose
        try:
            fit = fit_touches(touches, size, radius, _law(spec).force, rot, t)
        except ValueError as exc:  # the touches do not pin the pose down: not registered
            self._error(ctx, f"{exc}")
            return "out_of_tolerance"
        sigma = _top_sigma(fit, size)
        sigma_deg = math.degrees(float(np.sqrt(np.max(np.diag(fit.covariance)[3:6]))))
        ctx.metrics.update(
            {
                "registration_sigma_mm": round(sigma * 1000, 5),
                "registration_sigma_deg": round(sigma_deg, 5),
                "registration_fit_rms_n": round(fit.rms_n, 5),
                "registration_stiffness_scale": round(fit.scale, 4),
                "registration_touch_s": round(ctx.clock - self.t_touch, 3),
            }
        )
        ctx.log(
            "skill",
            f"register: {len(self.probes)} touches put {p.object!r} at "
            f"{np.round(fit.position, 5).tolist()} (1-sigma {sigma * 1000:.4f} mm, "
            f"{sigma_deg:.4f} deg), tissue {fit.scale:.3f} x the registered law",
        )
        if sigma > p.max_sigma_m:
            self._error(
                ctx,
                f"touched pose uncertain by {sigma * 1000:.3f} mm (limit "
                f"{p.max_sigma_m * 1000:.3f})",
            )
            return "out_of_tolerance"
        return self._write(ctx, fit.position, fit.rotation, scale=fit.scale)

    # -- result -------------------------------------------------------------------------
    def _write(self, ctx: Context, pos: np.ndarray, rot: np.ndarray, scale: float) -> str:
        p = self.params
        spec = ctx.scenario.scene.phantom
        assert spec is not None
        if not self._near_plan(ctx, pos):
            return "out_of_tolerance"
        law = _law(spec, scale)
        ctx.blackboard[p.into] = Pose(pos=pos.tolist(), quat=_quat(rot).tolist())
        ctx.blackboard[p.stiffness_into] = (
            law.stiffness if p.at_force_n is None else law.tangent_stiffness(p.at_force_n)
        )
        return "registered"

    def _near_plan(self, ctx: Context, pos: np.ndarray) -> bool:
        """Whether `pos` is within `max_offset_m` of the planned place (in the metrics)."""
        p = self.params
        spec = ctx.scenario.scene.phantom
        assert spec is not None
        planned = np.array([*spec.xy, ctx.world.table_height + spec.size[2]])
        offset = float(np.linalg.norm(pos - planned))
        ctx.metrics["registration_offset_mm"] = round(offset * 1000, 4)
        if offset <= p.max_offset_m:
            return True
        self._error(
            ctx,
            f"{p.object!r} {offset * 1000:.1f} mm from the plan (limit "
            f"{p.max_offset_m * 1000:.1f})",
        )
        return False


def _default_touches(size: np.ndarray) -> list[TouchPoint]:
    """3 on the top, 2 on the edge of the top with the -y side, 1 on its edge with the -x end
    (clear of the +y half, where zones lie in the bundled scenes)."""
    sx, sy = float(size[0]) / 2, float(size[1]) / 2
    return [  # in an order that keeps the moves between them short
        TouchPoint(on="top", at=[0.0, 0.1 * sy, 0.0]),
        TouchPoint(on="top", at=[0.7 * sx, -0.6 * sy, 0.0]),
        TouchPoint(on="-y", at=[0.6 * sx, -sy, 0.0]),
        TouchPoint(on="-y", at=[-0.6 * sx, -sy, 0.0]),
        TouchPoint(on="top", at=[-0.7 * sx, -0.6 * sy, 0.0]),
        TouchPoint(on="-x", at=[-sx, -0.4 * sy, 0.0]),
    ]


def _outward(on: str) -> np.ndarray:
    """Outward direction of a touch in the surface frame: the top's normal, or on an edge of
    the top the bisector of its normal and the side's. Shape (3,)."""
    top = np.array([0.0, 0.0, 1.0])
    if on == "top":
        return top
    return (top + np.array(FACES[on])) / math.sqrt(2.0)


def _law(spec: Any, scale: float = 1.0) -> TissueLaw:
    """The phantom's registered force law (`scene.phantom`), its stiffness times `scale`."""
    return TissueLaw(
        stiffness=spec.stiffness_n_per_m * scale,
        damping=spec.damping_n_s_per_m,
        ratio=spec.stiffening.ratio,
        depth_m=spec.stiffening.depth_m,
    )


def _top_sigma(fit: TouchFit, size: np.ndarray) -> float:
    """Worst 1-sigma lateral error (along the frame's x or y) over the top surface's corners."""
    hx, hy = float(size[0]) / 2, float(size[1]) / 2
    worst = 0.0
    for corner in ([hx, hy, 0.0], [-hx, hy, 0.0], [-hx, -hy, 0.0], [hx, -hy, 0.0]):
        for axis in (fit.rotation[:, 0], fit.rotation[:, 1]):
            worst = max(worst, lateral_sigma(fit, np.array(corner), axis))
    return worst


def _quat(rot: np.ndarray) -> np.ndarray:
    """Quaternion (w, x, y, z) of a rotation matrix (shape (3, 3)), w >= 0."""
    import mujoco

    q = np.zeros(4)
    mujoco.mju_mat2Quat(q, np.ascontiguousarray(rot).reshape(9))
    return q if q[0] >= 0 else -q


def _kabsch(model: np.ndarray, measured: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Least-squares rotation (shape (3, 3)) and position [m] (shape (3,)) placing the points
    `model` (shape (k, 3), k >= 3, not collinear) on `measured` (Kabsch)."""
    mc, sc = model.mean(axis=0), measured.mean(axis=0)
    u, _, vt = np.linalg.svd((model - mc).T @ (measured - sc))
    flip = np.diag([1.0, 1.0, float(np.sign(np.linalg.det(vt.T @ u.T)))])
    rot = vt.T @ flip @ u.T
    return rot, sc - rot @ mc
