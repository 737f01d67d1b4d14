"""`gripper_clear`: the gripper let go of an object and stands clear of it."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, ClassVar

import numpy as np
from pydantic import Field

from .base import SCENE_OBJECT, CheckParams, SuccessCheck, Verdict

if TYPE_CHECKING:
    from ..engine.context import Context

__all__ = ["GripperClear"]


class GripperClearParams(CheckParams):
    object: str = Field(description="The scene object judged.", json_schema_extra=SCENE_OBJECT)
    min_distance_m: float = Field(
        default=0.01, ge=0.0, le=10.0, description="Finger clearance [m]."
    )


class GripperClear(SuccessCheck):
    """The gripper is open wider than the object's narrower side (what a hand closes across)
    and every finger is at least `min_distance_m` from it (MuJoCo's geom distance). (Its
    largest edge was used: a 0.67 m box grasped across its 5 cm side failed the check.)"""

    kind: ClassVar[str] = "gripper_clear"
    Params: ClassVar[type[CheckParams]] = GripperClearParams
    params: GripperClearParams

    def evaluate(self, ctx: Context) -> Verdict:
        import mujoco

        p = self.params
        handle = ctx.world.objects[p.object]
        need = 2.0 * float(min(handle.half_size[:2])) + 2.0 * p.min_distance_m
        fromto = np.zeros(6)
        nearest = math.inf
        for g in ctx.world.finger_geoms:
            dist = mujoco.mj_geomDistance(
                ctx.model, ctx.data, g, handle.geom_id, p.min_distance_m + 0.05, fromto
            )
            nearest = min(nearest, float(dist))
        gap = (
            f"fingers {nearest * 1000:.1f} mm from {p.object} (min_distance_m {p.min_distance_m:g})"
        )
        if nearest < p.min_distance_m:
            return Verdict(False, gap)
        if ctx.gripper_width < need:
            return Verdict(
                False, f"gripper open {ctx.gripper_width * 1000:.1f} mm < {need * 1000:.1f} mm"
            )
        return Verdict(True, gap)
