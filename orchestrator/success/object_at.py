"""`object_at`: an object rests on the table at a target, upright."""

from __future__ import annotations

from typing import TYPE_CHECKING, ClassVar

import numpy as np
from pydantic import Field

from ..exceptions import OrchestratorError
from ..skills.targets import resolve_target
from ..world.pose import Pose
from .base import SCENE_OBJECT, SCENE_TARGET, CheckParams, SuccessCheck, Vec3, Verdict
from .geometry import tilt_deg

if TYPE_CHECKING:
    from ..engine.context import Context

__all__ = ["ObjectAt"]

RESTING_M = 0.01
"""An object whose bottom is this far above the table or more is not resting on it [m]."""


class ObjectAtParams(CheckParams):
    object: str = Field(description="The scene object judged.", json_schema_extra=SCENE_OBJECT)
    target: str | Vec3 = Field(
        description="A marker or object name, `[x, y, z]` [m], or `$key` to follow the "
        "blackboard (where the flow was told to place, e.g. `$place_at`).",
        json_schema_extra=SCENE_TARGET,
    )
    xy_tol_m: float = Field(default=0.01, gt=0.0, le=10.0, description="Horizontal tolerance [m].")
    upright_tol_deg: float = Field(
        default=10.0, gt=0.0, le=180.0, description="Largest tilt [deg]."
    )


class ObjectAt(SuccessCheck):
    """The object rests on the table (its bottom less than 10 mm above it) within `xy_tol_m`
    of the target in the table plane, tilted at most `upright_tol_deg`. Metric:
    `<name>_xy_error_mm`, its centre's distance from the target in the table plane."""

    kind: ClassVar[str] = "object_at"
    Params: ClassVar[type[CheckParams]] = ObjectAtParams
    params: ObjectAtParams

    def _goal(self, ctx: Context) -> Pose:
        # a `$key` target follows the blackboard: where the flow was told to place
        return resolve_target(ctx, ctx.blackboard.resolve(self.params.target))

    def evaluate(self, ctx: Context) -> Verdict:
        p = self.params
        pose = ctx.object_pose(p.object)
        handle = ctx.world.objects[p.object]
        try:
            goal = self._goal(ctx)
        except OrchestratorError as exc:
            return Verdict(False, f"target {p.target!r}: {exc}")
        xy_err = float(np.linalg.norm(np.asarray(pose.pos[:2]) - np.asarray(goal.pos[:2])))
        tilt = tilt_deg(pose.quat)
        height = pose.pos[2] - ctx.world.table_height - handle.half_size[2]
        where = np.round(np.asarray(goal.pos[:2]), 3).tolist()
        problems = []
        if xy_err > p.xy_tol_m:
            problems.append(
                f"{p.object} is {xy_err * 1000:.1f} mm from {where} (xy_tol_m "
                f"{p.xy_tol_m * 1000:g} mm)"
            )
        if tilt > p.upright_tol_deg:
            problems.append(f"tilted {tilt:.1f} deg (upright_tol_deg {p.upright_tol_deg:g})")
        if height >= RESTING_M:
            problems.append(f"not resting on the table ({height * 1000:.0f} mm above it)")
        if problems:
            return Verdict(False, "; ".join(problems))
        done = f"{p.object} {xy_err * 1000:.1f} mm from {where}, tilted {tilt:.1f} deg"
        return Verdict(True, done)

    def metrics(self, ctx: Context) -> dict[str, float]:
        pos = ctx.object_pose(self.params.object).pos
        try:
            goal = self._goal(ctx)
        except OrchestratorError:
            return {}  # `evaluate` reports why the target cannot be found
        err = float(np.linalg.norm(np.asarray(pos[:2]) - np.asarray(goal.pos[:2])))
        return {"xy_error_mm": round(err * 1000.0, 3)}
