"""`search`: find a named object and write its (noisy) pose to the blackboard."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, ClassVar

import numpy as np
from pydantic import Field, NonNegativeFloat

from orchestrator.world.pose import Pose, quat_from_yaw

from .base import SCENE_OBJECT, Skill, SkillParams
from .hint import Hint, HintRadius, hint_distance

if TYPE_CHECKING:
    from orchestrator.engine.context import Context

__all__ = ["Search"]


class SearchParams(SkillParams):
    object: str = Field(
        description="Name of the scene object to look for.", json_schema_extra=SCENE_OBJECT
    )
    into: str = Field(default="object_pose", description="Blackboard key the pose is written to.")
    duration_s: NonNegativeFloat = Field(default=0.1, description="Time the perception takes [s].")
    near: Hint = None
    near_radius_m: HintRadius = 0.05


class Search(Skill):
    """The perception oracle: after `duration_s`, `found` with the object's true pose from the
    simulator (plus the scenario's perception noise) written to `into`, or `not_found` if the
    object is not in view (unknown, or no longer on the table) or, given a position hint
    `near`, not within `near_radius_m` of it. Injected perception faults (`perception_miss`,
    `perception_offset`) apply to what it reports."""

    name: ClassVar[str] = "search"
    Params: ClassVar[type[SkillParams]] = SearchParams
    outcomes: ClassVar[tuple[str, ...]] = ("found", "not_found")
    writes: ClassVar[dict[str, str]] = {"into": "pose"}

    params: SearchParams

    def start(self, ctx: Context) -> None:
        self.t0 = ctx.clock

    def step(self, ctx: Context) -> str | None:
        if ctx.clock - self.t0 < self.params.duration_s:
            return None
        name = self.params.object
        if name not in ctx.world.objects:
            ctx.log("skill", f"search: no object {name!r} in the scene")
            return "not_found"
        true = ctx.object_pose(name)
        if true.pos[2] < ctx.world.table_height - 0.02 or not _upright(true):
            ctx.log("skill", f"search: {name!r} is not on the table")
            return "not_found"
        noise = ctx.scenario.perception
        pos = np.asarray(true.pos) + ctx.rng.normal(0.0, noise.position_noise_m, 3) * [1, 1, 0]
        yaw = true.yaw + ctx.rng.normal(0.0, math.radians(noise.yaw_noise_deg))
        seen = ctx.perceived(Pose(pos=pos.tolist(), quat=quat_from_yaw(yaw).tolist()))
        if seen is None:
            ctx.log("skill", f"search: perception found no {name!r}")
            return "not_found"
        hint = self.params.near
        if hint is not None and hint_distance(hint, seen.pos) > self.params.near_radius_m:
            ctx.log("skill", f"search: no {name!r} within {self.params.near_radius_m} m of {hint}")
            return "not_found"
        ctx.blackboard[self.params.into] = seen
        ctx.log("skill", f"search: found {name!r} at {np.round(seen.pos, 4).tolist()}")
        return "found"


def _upright(pose: Pose, tol_deg: float = 15.0) -> bool:
    w, x, y, z = pose.quat
    zz = 1.0 - 2.0 * (x * x + y * y)  # world z component of the body z axis
    return zz >= math.cos(math.radians(tol_deg))
