"""`register`: locate the phantom by its fiducials and write its registered pose."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, ClassVar

import numpy as np
from pydantic import Field, NonNegativeFloat, PositiveFloat, PositiveInt

from orchestrator.world.pose import Pose, quat_from_yaw

from .base import Skill, SkillParams

if TYPE_CHECKING:
    from orchestrator.engine.context import Context

__all__ = ["Register"]


class RegisterParams(SkillParams):
    object: str = Field(default="phantom", description="The phantom to register, by name.")
    into: str = Field(
        default="phantom_pose",
        description="Blackboard key the registered pose of its top-surface centre goes to.",
    )
    stiffness_into: str = Field(
        default="phantom_stiffness",
        description="Blackboard key its registered (nominal) stiffness [N/m] goes to.",
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


class Register(Skill):
    """Search for the phantom's four fiducials (the corners of its top surface, `inset_m`
    inside) with the scenario's perception noise, `samples` times each, and fit its pose
    (x, y, z, yaw: least squares, Kabsch in the plane).

    Outcomes: `registered` (the fiducial registration error — RMS distance of the measured
    fiducials to the fitted model — is within `tolerance_m` and the pose within
    `max_offset_m` of the plan), `not_found` (no such phantom), `out_of_tolerance`. Metrics:
    `registration_fre_mm`, `registration_offset_mm` (from the planned pose).
    """

    name: ClassVar[str] = "register"
    Params: ClassVar[type[SkillParams]] = RegisterParams
    outcomes: ClassVar[tuple[str, ...]] = ("registered", "not_found", "out_of_tolerance")
    writes: ClassVar[dict[str, str]] = {"into": "pose", "stiffness_into": "float"}

    params: RegisterParams

    def start(self, ctx: Context) -> None:
        self.t0 = ctx.clock

    def step(self, ctx: Context) -> str | None:
        p = self.params
        if ctx.clock - self.t0 < p.duration_s - 1e-9:
            return None
        phantom = ctx.world.phantom
        if phantom is None or phantom.name != p.object:
            ctx.log("skill", f"register: no phantom {p.object!r} in the scene", level="ERROR")
            return "not_found"
        hx, hy = phantom.size[0] / 2 - p.inset_m, phantom.size[1] / 2 - p.inset_m
        model_pts = np.array([[hx, hy, 0.0], [-hx, hy, 0.0], [-hx, -hy, 0.0], [hx, -hy, 0.0]])
        truth = _place(model_pts, phantom.surface_pos, phantom.yaw)
        sigma = ctx.scenario.perception.position_noise_m
        noise = ctx.rng.normal(0.0, sigma, (p.samples, *truth.shape))
        seen = [ctx.perceived(Pose(pos=pt.tolist())) for pt in truth + noise.mean(axis=0)]
        if any(s is None for s in seen):
            ctx.log("skill", f"register: a fiducial of {p.object!r} was not found", level="ERROR")
            return "not_found"
        measured = np.array([s.pos for s in seen if s is not None])
        pos, yaw = _fit(model_pts, measured)
        fre = float(np.sqrt(np.mean(np.sum((_place(model_pts, pos, yaw) - measured) ** 2, 1))))
        spec = ctx.scenario.scene.phantom
        assert spec is not None
        planned = np.array([*spec.xy, ctx.world.table_height + spec.size[2]])
        offset = float(np.linalg.norm(pos - planned))
        ctx.metrics["registration_fre_mm"] = round(fre * 1000, 4)
        ctx.metrics["registration_offset_mm"] = round(offset * 1000, 4)
        if fre > p.tolerance_m or offset > p.max_offset_m:
            ctx.log(
                "skill",
                f"register: {p.object!r} fiducial error {fre * 1000:.2f} mm (limit "
                f"{p.tolerance_m * 1000:.2f}), {offset * 1000:.1f} mm from the plan (limit "
                f"{p.max_offset_m * 1000:.1f})",
                level="ERROR",
            )
            return "out_of_tolerance"
        ctx.blackboard[p.into] = Pose(pos=pos.tolist(), quat=quat_from_yaw(yaw).tolist())
        ctx.blackboard[p.stiffness_into] = float(spec.stiffness_n_per_m)
        ctx.log(
            "skill",
            f"register: {p.object!r} at {np.round(pos, 4).tolist()}, yaw "
            f"{math.degrees(yaw):.2f} deg, FRE {fre * 1000:.3f} mm",
        )
        return "registered"


def _place(points: np.ndarray, pos: np.ndarray, yaw: float) -> np.ndarray:
    """`points` (shape (k, 3)) of the surface frame placed at `pos` [m] turned by `yaw` [rad]."""
    c, s = math.cos(yaw), math.sin(yaw)
    rot = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    return points @ rot.T + pos


def _fit(model: np.ndarray, measured: np.ndarray) -> tuple[np.ndarray, float]:
    """Least-squares position [m] (shape (3,)) and yaw [rad] placing `model` on `measured`."""
    mc, sc = model.mean(axis=0), measured.mean(axis=0)
    a, b = model[:, :2] - mc[:2], measured[:, :2] - sc[:2]
    yaw = math.atan2(float(np.sum(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0])), float(np.sum(a * b)))
    c, s = math.cos(yaw), math.sin(yaw)
    pos = sc - np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]) @ mc
    return pos, yaw
