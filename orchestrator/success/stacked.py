"""`stacked`: an object rests on another object, centred and upright within tolerances."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, ClassVar

from pydantic import Field, model_validator

from .base import SCENE_OBJECT, CheckParams, SuccessCheck, Verdict
from .geometry import tilt_deg, z_extent

if TYPE_CHECKING:
    from ..engine.context import Context

__all__ = ["Stacked"]


class StackedParams(CheckParams):
    object: str = Field(description="The object on top.", json_schema_extra=SCENE_OBJECT)
    on_top_of: str = Field(
        description="The object it rests on (not `on:`, which YAML 1.1 reads as true).",
        json_schema_extra=SCENE_OBJECT,
    )
    xy_tol_m: float = Field(
        default=0.01,
        gt=0.0,
        le=1.0,
        description="Largest horizontal distance between the two centres [m].",
    )
    gap_tol_m: float = Field(
        default=0.003,
        gt=0.0,
        le=0.1,
        description="Largest gap (or overlap) between its bottom and the top of `on_top_of`: "
        "it rests on it, neither hovering above nor fallen beside it [m].",
    )
    upright_tol_deg: float = Field(
        default=10.0, gt=0.0, le=180.0, description="Largest tilt of either object [deg]."
    )

    @model_validator(mode="after")
    def _two_objects(self) -> StackedParams:
        if self.object == self.on_top_of:
            raise ValueError(f"`object` and `on_top_of` name the same object {self.object!r}")
        return self


class Stacked(SuccessCheck):
    """`object` rests on `on_top_of`: their centres within `xy_tol_m` of each other in the table
    plane, the bottom of `object` within `gap_tol_m` of the top of `on_top_of` (both measured as
    boxes along world z, whatever their tilt), and neither tilted more than
    `upright_tol_deg`. Metrics: `<name>_xy_error_mm` (centre to centre) and `<name>_gap_mm`
    (positive: above the top face)."""

    kind: ClassVar[str] = "stacked"
    Params: ClassVar[type[CheckParams]] = StackedParams
    params: StackedParams

    def _measure(self, ctx: Context) -> tuple[float, float, float, float]:
        """(centre distance in the table plane [m], gap [m], tilt of `object` and of
        `on_top_of` [deg])."""
        p = self.params
        top, base = ctx.object_pose(p.object), ctx.object_pose(p.on_top_of)
        h_top = ctx.object_handle(p.object).half_size
        h_base = ctx.object_handle(p.on_top_of).half_size
        xy = math.hypot(top.pos[0] - base.pos[0], top.pos[1] - base.pos[1])
        bottom = top.pos[2] - z_extent(top.quat, h_top)
        gap = bottom - (base.pos[2] + z_extent(base.quat, h_base))
        return xy, gap, tilt_deg(top.quat), tilt_deg(base.quat)

    def evaluate(self, ctx: Context) -> Verdict:
        p = self.params
        xy, gap, tilt, tilt_on = self._measure(ctx)
        gap_mm = round(gap * 1000.0, 1) or 0.0  # no "-0.0"
        what = (
            f"{p.object} {xy * 1000:.1f} mm off the centre of {p.on_top_of}, gap to its top "
            f"{gap_mm:+.1f} mm, tilted {tilt:.1f} deg"
        )
        problems = []
        if xy > p.xy_tol_m:
            problems.append(f"xy_tol_m {p.xy_tol_m * 1000:g} mm")
        if abs(gap) > p.gap_tol_m:
            problems.append(f"gap_tol_m {p.gap_tol_m * 1000:g} mm")
        if tilt > p.upright_tol_deg:
            problems.append(f"upright_tol_deg {p.upright_tol_deg:g}")
        if tilt_on > p.upright_tol_deg:
            what += f" ({p.on_top_of} tilted {tilt_on:.1f} deg)"
            problems.append(f"upright_tol_deg {p.upright_tol_deg:g} for {p.on_top_of}")
        if problems:
            return Verdict(False, f"{what}: over {', '.join(problems)}")
        return Verdict(True, what)

    def metrics(self, ctx: Context) -> dict[str, float]:
        xy, gap, _, _ = self._measure(ctx)
        return {"xy_error_mm": round(xy * 1000.0, 3), "gap_mm": round(gap * 1000.0, 3)}
