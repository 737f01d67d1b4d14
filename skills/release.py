"""`release`: open the gripper."""

from __future__ import annotations

from typing import TYPE_CHECKING, ClassVar

from pydantic import Field, PositiveFloat

from .base import Skill, SkillParams

if TYPE_CHECKING:
    from orchestrator.engine.context import Context

__all__ = ["Release"]


class ReleaseParams(SkillParams):
    opening_m: PositiveFloat | None = Field(
        default=None, description="Per-finger opening [m] (default: fully open)."
    )
    timeout_s: PositiveFloat = Field(default=1.0, description="[s]")


class Release(Skill):
    """Open the fingers to `opening_m`: `released` once they are there, else `timeout`."""

    name: ClassVar[str] = "release"
    Params: ClassVar[type[SkillParams]] = ReleaseParams
    outcomes: ClassVar[tuple[str, ...]] = ("released", "timeout")

    params: ReleaseParams

    def start(self, ctx: Context) -> None:
        self.opening = min(
            self.params.opening_m or ctx.robot.gripper_open_m, ctx.robot.gripper_open_m
        )
        self.t0 = ctx.clock
        ctx.controller.hold_setpoint()
        ctx.set_gripper(self.opening)

    def step(self, ctx: Context) -> str | None:
        if ctx.gripper_width >= 2 * self.opening - 0.002:
            return "released"
        if ctx.clock - self.t0 > self.params.timeout_s:
            return "timeout"
        return None

    def stop(self, ctx: Context) -> None:
        ctx.controller.hold_setpoint()
