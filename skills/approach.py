"""`approach`: the mobile base to a standoff from a detected object, facing it all the way."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np
from orchestrator.robots.mobile import BASE
from pydantic import Field, PositiveFloat

from .base import SCENE_TARGET, SkillParams
from .base_map import base_map
from .base_motion import BaseMotionParams, BaseMotionSkill, back_out, base_pose
from .targets import resolve_target

if TYPE_CHECKING:
    from orchestrator.engine.context import Context

__all__ = ["Approach"]

_HEADINGS = 36
"""Directions tried around the object (every 10 deg)."""
_RUN_IN_M = 0.5
"""The last stretch, straight at the object, starts this far behind the standoff [m]: the
planned path (which keeps the planning radius from every box) ends there."""


_ARM_HALF_WIDTH_M = 0.12
"""Half width of the corridor the arm reaches down through to the target [m] (the hand with
open fingers is 0.2 m across)."""


class ApproachParams(BaseMotionParams):
    target: Any = Field(
        description="What to approach: a pose (`$object_pose`, from `detect`), an object or "
        "marker name, or `[x, y, z]` [m].",
        json_schema_extra=SCENE_TARGET,
    )
    standoff_m: PositiveFloat = Field(
        default=0.62,
        le=5.0,
        description="Horizontal distance from the base's centre to the target at the end [m] "
        "(0.62: the target 0.5 m ahead of the arm's base, where the Panda grasps from above).",
    )
    margin_m: float = Field(
        default=0.05, ge=0.0, le=0.5, description="Clearance of the chassis from every box [m]."
    )
    face_offset_deg: float = Field(
        default=0.0,
        ge=-90.0,
        le=90.0,
        description="The base ends turned this far from facing the target (counter-clockwise) "
        "[deg]: a camera behind the arm then sees the target beside the arm, not behind it.",
    )


class Approach(BaseMotionSkill):
    """Bring the base to `standoff_m` from the target, facing it, keeping it in view: the base
    turns to the target at every corner of its path (a camera on the base keeps it in the
    image), and the last stretch runs straight at it.

    Of the directions around the target (every 10 deg) whose standoff pose keeps the chassis
    `margin_m` clear of the room's boxes, and from which the arm reaches the target without
    passing over anything taller than the surface it rests on, it takes the one with the
    shortest path from where the base is. Outcomes: `reached`, `blocked` (no free standoff or
    no path), `timeout`. Adds to `base_travel_m`; the first approach of a run sets
    `search_time_s` (the time until then).
    """

    name: ClassVar[str] = "approach"
    Params: ClassVar[type[SkillParams]] = ApproachParams
    outcomes: ClassVar[tuple[str, ...]] = ("reached", "blocked", "timeout")

    params: ApproachParams

    def start(self, ctx: Context) -> None:
        ctx.metrics.setdefault("search_time_s", round(ctx.clock, 3))
        super().start(ctx)

    def plan(self, ctx: Context) -> list[np.ndarray] | None:
        p = self.params
        target3 = np.asarray(resolve_target(ctx, p.target).pos, float)
        target = target3[:2]
        room = base_map(ctx.scenario)
        here = base_pose(ctx)
        lead = back_out(ctx, room, here)
        if lead is None:
            return None
        start = lead[-1][:2] if lead else here[:2]
        rect = (BASE.length_m / 2, BASE.width_m / 2)
        options = []
        for k in range(_HEADINGS):
            th = 2.0 * math.pi * k / _HEADINGS
            u = np.array([math.cos(th), math.sin(th)])
            stand = target - p.standoff_m * u
            run_in = stand - _RUN_IN_M * u
            if not room.is_free(*run_in) or not room.reach_clear(stand, target3, _ARM_HALF_WIDTH_M):
                continue
            steps = np.linspace(0.0, 1.0, 6)
            if not all(
                room.footprint_clear(*(run_in + s * (stand - run_in)), th, p.margin_m, rect)
                for s in steps
            ):
                continue
            options.append((float(np.linalg.norm(run_in - start)), th, stand, run_in))
        for _, th, stand, run_in in sorted(options, key=lambda o: o[0]):
            corners = room.plan(start, run_in)
            if corners is None:
                continue
            poses = [*lead, *(np.array([*c, _facing(c, target)]) for c in corners)]
            poses.append(np.array([*stand, th + math.radians(p.face_offset_deg)]))
            ctx.log(
                "skill",
                f"approach: standoff {np.round(stand, 3).tolist()} facing "
                f"{math.degrees(th):.0f} deg, {len(poses)} segment(s)",
            )
            return poses
        ctx.log(
            "skill",
            f"approach: no free standoff around {np.round(target, 3).tolist()}",
            level="WARN",
        )
        return None


def _facing(point: np.ndarray, target: np.ndarray) -> float:
    d = target - point
    return math.atan2(float(d[1]), float(d[0]))
