"""`hold`: stop where the arm is and hold that pose compliantly for a while."""

from __future__ import annotations

from typing import TYPE_CHECKING, ClassVar

from pydantic import Field, PositiveFloat

from . import impedance
from .base import Skill, SkillParams

if TYPE_CHECKING:
    from orchestrator.context import Context

__all__ = ["Hold"]


class HoldParams(SkillParams):
    duration_s: PositiveFloat = Field(default=0.5, description="How long to hold [s].")
    stiffness_n_per_m: PositiveFloat = Field(
        default=2000.0, le=10000.0, description="Translational impedance [N/m]."
    )
    rotational_stiffness: PositiveFloat = Field(
        default=60.0, le=500.0, description="Rotational impedance [Nm/rad]."
    )
    damping_ratio: PositiveFloat = Field(
        default=1.5, le=5.0, description="Damping relative to critical (above 1: no rebound)."
    )


class Hold(Skill):
    """Cartesian impedance about the TCP pose measured on entry, for `duration_s`: `held`.

    Holding the measured pose, not the last setpoint, is what stops the arm: any preload a
    previous skill had (pressing into a surface) is released at once, and the damping brings
    the arm to rest. The impedance keeps a contact compliant while it holds.
    """

    name: ClassVar[str] = "hold"
    Params: ClassVar[type[SkillParams]] = HoldParams
    outcomes: ClassVar[tuple[str, ...]] = ("held",)

    params: HoldParams

    def start(self, ctx: Context) -> None:
        p = self.params
        self.t0 = ctx.t
        gains = impedance.gains(p.stiffness_n_per_m, p.rotational_stiffness, p.damping_ratio)
        impedance.command(ctx, ctx.tcp_pos.copy(), ctx.tcp_rot.copy(), gains, ctx.q.copy())

    def step(self, ctx: Context) -> str | None:
        return "held" if ctx.t - self.t0 >= self.params.duration_s - 1e-9 else None

    def stop(self, ctx: Context) -> None:
        """Keep the compliant hold (the next skill takes over from its setpoint)."""
