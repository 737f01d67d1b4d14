"""`zero_sensor`: zero the wrist force sensor at rest (remove the tool's weight) and verify."""

from __future__ import annotations

from typing import TYPE_CHECKING, ClassVar

import numpy as np
from pydantic import Field, PositiveFloat

from .base import Skill, SkillParams

if TYPE_CHECKING:
    from orchestrator.engine.context import Context

__all__ = ["ZeroSensor"]


class ZeroSensorParams(SkillParams):
    window_s: PositiveFloat = Field(default=0.2, description="Averaging window [s].")
    verify_s: PositiveFloat = Field(
        default=0.2, description="Time the zeroed reading is checked afterwards [s]."
    )
    tolerance_n: PositiveFloat = Field(
        default=0.05, description="Largest zeroed reading allowed while verifying [N]."
    )
    max_joint_speed: PositiveFloat = Field(
        default=0.01, description="Joint speed above which the arm is not at rest [rad/s]."
    )


class ZeroSensor(Skill):
    """Hold still, average the wrist force over `window_s` and remove it from every later
    reading (`ctx.zero_wrist_force`); then check for `verify_s` that the reading stays within
    `tolerance_n`: `zeroed`, else `out_of_tolerance` (the arm moved, or something touches it).

    Metrics: `ft_offset_n` (the offset removed) and `ft_zero_residual_n` (largest reading
    while verifying).
    """

    name: ClassVar[str] = "zero_sensor"
    Params: ClassVar[type[SkillParams]] = ZeroSensorParams
    outcomes: ClassVar[tuple[str, ...]] = ("zeroed", "out_of_tolerance")

    params: ZeroSensorParams

    def start(self, ctx: Context) -> None:
        self.t0 = ctx.clock
        self.samples: list[np.ndarray] = []
        self.residual = 0.0
        self.zeroed_at: float | None = None
        self.max_speed = 0.0
        ctx.controller.hold(ctx.q.copy())

    def step(self, ctx: Context) -> str | None:
        p = self.params
        self.max_speed = max(self.max_speed, float(np.max(np.abs(ctx.qd))))
        force = ctx.wrist_force()
        if self.zeroed_at is None:
            self.samples.append(force.copy())
            if ctx.clock - self.t0 < p.window_s - 1e-9:
                return None
            offset = np.mean(self.samples, axis=0)
            ctx.zero_wrist_force(offset)
            ctx.metrics["ft_offset_n"] = round(float(np.linalg.norm(offset)), 4)
            self.zeroed_at = ctx.clock
            return None
        self.residual = max(self.residual, float(np.linalg.norm(force)))
        if ctx.clock - self.zeroed_at < p.verify_s - 1e-9:
            return None
        ctx.metrics["ft_zero_residual_n"] = round(self.residual, 4)
        if self.max_speed > p.max_joint_speed:
            ctx.log(
                "skill", f"zero_sensor: the arm moved ({self.max_speed:.3f} rad/s)", level="ERROR"
            )
            return "out_of_tolerance"
        if self.residual > p.tolerance_n:
            ctx.log(
                "skill",
                f"zero_sensor: {self.residual:.3f} N after zeroing exceeds {p.tolerance_n} N",
                level="ERROR",
            )
            return "out_of_tolerance"
        ctx.log("skill", f"zero_sensor: zeroed (residual {self.residual:.4f} N)")
        return "zeroed"
