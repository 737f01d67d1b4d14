"""`turn`: the mobile base turns in place by an angle (a camera on it sweeps the room)."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, ClassVar

import numpy as np
from pydantic import Field

from .base import SkillParams
from .base_motion import BaseMotionParams, BaseMotionSkill

if TYPE_CHECKING:
    from orchestrator.engine.context import Context

__all__ = ["Turn"]


class TurnParams(BaseMotionParams):
    by_deg: float = Field(
        ge=-360.0,
        le=360.0,
        description="Angle to turn by, counter-clockwise seen from above [deg].",
    )


class Turn(BaseMotionSkill):
    """Turn the base in place by `by_deg` on a jerk-limited timing law (the arm held), from the
    base's commanded yaw, so that steps add up exactly. Cameras on the robot turn with it:
    `detect` between turns sweeps the room.

    Outcomes: `turned` (within tolerance), `timeout` (the base did not settle). Adds to
    `base_travel_m` (the little the base's centre drifts).
    """

    name: ClassVar[str] = "turn"
    Params: ClassVar[type[SkillParams]] = TurnParams
    outcomes: ClassVar[tuple[str, ...]] = ("turned", "timeout")
    arrived: ClassVar[str] = "turned"
    wrap_yaw: ClassVar[bool] = False

    params: TurnParams

    def plan(self, ctx: Context) -> list[np.ndarray] | None:
        q_d = ctx.controller.q_d
        origin = ctx.scenario.robot.base_pos
        yaw = float(q_d[2]) + math.radians(self.params.by_deg)
        return [np.array([q_d[0] + origin[0], q_d[1] + origin[1], yaw])]
