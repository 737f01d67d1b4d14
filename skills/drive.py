"""`drive`: the mobile base to a pose in the room, around the furniture."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Annotated, ClassVar

import numpy as np
from pydantic import Field

from .base import SkillParams
from .base_map import base_map
from .base_motion import BaseMotionParams, BaseMotionSkill, back_out, base_pose, wrap_angle

if TYPE_CHECKING:
    from orchestrator.engine.context import Context

__all__ = ["Drive"]


class DriveParams(BaseMotionParams):
    to: Annotated[list[float], Field(min_length=3, max_length=3)] = Field(
        description="Goal pose of the base in the world: `[x, y, yaw_deg]` ([m], [m], [deg])."
    )
    plan: bool = Field(
        default=True,
        description="Go around the scene's fixed boxes (A* on the room's map); false: "
        "straight there, whatever is in the way.",
    )


class Drive(BaseMotionSkill):
    """Drive the base to `to` (turning on the way), along a collision-free path through the
    room's map when `plan` is on: straight segments, each on a jerk-limited timing law within
    the base's speed and acceleration limits, the arm held.

    Outcomes: `reached` (within tolerance), `blocked` (no collision-free path to the goal),
    `timeout` (the base did not settle). Adds to `base_travel_m`.
    """

    name: ClassVar[str] = "drive"
    Params: ClassVar[type[SkillParams]] = DriveParams
    outcomes: ClassVar[tuple[str, ...]] = ("reached", "blocked", "timeout")

    params: DriveParams

    def plan(self, ctx: Context) -> list[np.ndarray] | None:
        x, y, yaw_deg = self.params.to
        goal = np.array([x, y, math.radians(yaw_deg)])
        if not self.params.plan:
            return [goal]
        here = base_pose(ctx)
        room = base_map(ctx.scenario)
        lead = back_out(ctx, room, here)
        if lead is None:
            return None
        start = lead[-1] if lead else here
        corners = room.plan(start[:2], goal[:2])
        if corners is None:
            ctx.log("skill", f"drive: no collision-free path to {self.params.to}", level="WARN")
            return None
        # turn on the way: the yaw changes in proportion to the distance covered
        starts = [start[:2], *corners[:-1]]
        lengths = np.cumsum([np.linalg.norm(c - a) for a, c in zip(starts, corners, strict=True)])
        total = float(lengths[-1]) or 1.0
        dyaw = wrap_angle(goal[2] - start[2])
        return lead + [
            np.array([*c, start[2] + dyaw * float(s) / total])
            for c, s in zip(corners, lengths, strict=True)
        ]
