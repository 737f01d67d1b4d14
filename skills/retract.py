"""`retract`: back the tool out along its own axis, slowly, in Cartesian impedance."""

from __future__ import annotations

from typing import TYPE_CHECKING, ClassVar

import numpy as np
from pydantic import Field, PositiveFloat

from . import impedance
from .base import Skill, SkillParams
from .trajectory import Profile

if TYPE_CHECKING:
    from orchestrator.engine.context import Context

__all__ = ["Retract"]


class RetractParams(SkillParams):
    distance_m: PositiveFloat = Field(default=0.02, le=0.3, description="How far to back out [m].")
    speed: PositiveFloat = Field(default=0.01, le=0.2, description="[m/s]")
    accel: PositiveFloat = Field(default=0.1, le=2.0, description="[m/s^2]")
    stiffness_n_per_m: PositiveFloat = Field(
        default=2000.0, le=10000.0, description="Translational impedance [N/m]."
    )
    rotational_stiffness: PositiveFloat = Field(
        default=60.0, le=500.0, description="Rotational impedance [Nm/rad]."
    )
    tolerance_m: PositiveFloat = Field(
        default=0.002, description="Distance of the tip from the end point that counts [m]."
    )
    settle_s: PositiveFloat = Field(
        default=1.0, description="Time allowed after the motion to get within tolerance [s]."
    )


class Retract(Skill):
    """Move the TCP `distance_m` back along the tool axis (the TCP's -z) from where the
    controller holds it, on a jerk-limited profile.

    Outcomes: `retracted` (the tip is within tolerance of the end point), `blocked` (it is
    not, `settle_s` after the motion: something holds the tool).
    """

    name: ClassVar[str] = "retract"
    Params: ClassVar[type[SkillParams]] = RetractParams
    outcomes: ClassVar[tuple[str, ...]] = ("retracted", "blocked")

    params: RetractParams

    def start(self, ctx: Context) -> None:
        p = self.params
        self.gains = impedance.gains(p.stiffness_n_per_m, p.rotational_stiffness)
        self.pos0, self.rot = impedance.setpoint(ctx, self.gains)
        back = -self.rot[:, 2]  # the tool points along the TCP's z axis
        self.end = self.pos0 + p.distance_m * back
        self.profile = Profile(p.distance_m, p.speed, p.accel)
        self.q_null = ctx.q.copy()
        self.t0 = ctx.clock

    def step(self, ctx: Context) -> str | None:
        p = self.params
        elapsed = ctx.clock - self.t0
        s, _ = self.profile.progress(elapsed)
        pos = self.pos0 + s * (self.end - self.pos0)
        impedance.command(ctx, pos, self.rot, self.gains, self.q_null)
        if elapsed < self.profile.duration:
            return None
        if float(np.linalg.norm(ctx.tcp_pos - self.end)) <= p.tolerance_m:
            return "retracted"
        if elapsed >= self.profile.duration + p.settle_s:
            ctx.log("skill", "retract: the tool did not reach the end point", level="WARNING")
            return "blocked"
        return None

    def stop(self, ctx: Context) -> None:
        """Keep the compliant hold at the last setpoint."""
