"""`hold`: stop the arm where it is and hold that pose for a while."""

from __future__ import annotations

from typing import TYPE_CHECKING, ClassVar

from pydantic import Field, PositiveFloat

from .base import Skill, SkillParams

if TYPE_CHECKING:
    from orchestrator.engine.context import Context

__all__ = ["Hold"]


class HoldParams(SkillParams):
    duration_s: PositiveFloat = Field(default=0.5, description="How long to hold [s].")


class Hold(Skill):
    """Hold the joint angles measured on entry, at zero velocity, for `duration_s`: `held`.

    This is the built-in safe stop as a skill, for an `on_abort` machine to continue from:
    holding the measured joints (not the last setpoint) brakes every joint at once, including
    the posture the Cartesian impedance leaves free, and releases any preload a previous skill
    had (pressing on a surface).
    """

    name: ClassVar[str] = "hold"
    Params: ClassVar[type[SkillParams]] = HoldParams
    outcomes: ClassVar[tuple[str, ...]] = ("held",)

    params: HoldParams

    def start(self, ctx: Context) -> None:
        self.t0 = ctx.clock
        ctx.controller.hold(ctx.q.copy())

    def step(self, ctx: Context) -> str | None:
        return "held" if ctx.clock - self.t0 >= self.params.duration_s - 1e-9 else None
