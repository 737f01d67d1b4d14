"""`check_tool`: is the expected instrument mounted? Its identity and its weight on the wrist."""

from __future__ import annotations

from typing import TYPE_CHECKING, ClassVar

import numpy as np
from pydantic import Field, PositiveFloat

from .base import Skill, SkillParams

if TYPE_CHECKING:
    from orchestrator.engine.context import Context

__all__ = ["CheckTool"]


class CheckToolParams(SkillParams):
    tool: str | None = Field(default=None, description="Expected tool name (default: any tool).")
    weight_tolerance_n: PositiveFloat = Field(
        default=0.3, description="Allowed difference between measured and declared weight [N]."
    )
    window_s: PositiveFloat = Field(default=0.2, description="Averaging window at rest [s].")


class CheckTool(Skill):
    """Check the mounted instrument at rest: `mounted` if the robot carries the expected tool
    and the wrist sensor feels its declared weight, else `missing`.

    Run it before `zero_sensor`: it reads the sensor against its factory calibration (the bare
    hand), which zeroing replaces. The measured weight goes to `metrics.tool_weight_n`.
    """

    name: ClassVar[str] = "check_tool"
    Params: ClassVar[type[SkillParams]] = CheckToolParams
    outcomes: ClassVar[tuple[str, ...]] = ("mounted", "missing")

    params: CheckToolParams

    def start(self, ctx: Context) -> None:
        self.t0 = ctx.clock
        self.samples: list[np.ndarray] = []
        ctx.controller.hold(ctx.q.copy())

    def step(self, ctx: Context) -> str | None:
        self.samples.append(ctx.wrist_force().copy())
        if ctx.clock - self.t0 < self.params.window_s - 1e-9:
            return None
        tool = getattr(ctx.robot, "tool", None)
        expected = self.params.tool
        if tool is None:
            ctx.log("skill", "check_tool: no instrument mounted", level="ERROR")
            return "missing"
        if expected is not None and tool.name != expected:
            ctx.log(
                "skill", f"check_tool: {tool.name!r} mounted, expected {expected!r}", level="ERROR"
            )
            return "missing"
        measured = np.mean(self.samples, axis=0)
        weight = tool.mass_kg * ctx.model.opt.gravity  # the force the tool pulls the hand with
        error = float(np.linalg.norm(measured - weight))
        ctx.metrics["tool_weight_n"] = round(float(np.linalg.norm(measured)), 4)
        if error > self.params.weight_tolerance_n:
            ctx.log(
                "skill",
                f"check_tool: the wrist feels {np.linalg.norm(measured):.2f} N, {tool.name!r} "
                f"weighs {np.linalg.norm(weight):.2f} N (not seated, or another tool)",
                level="ERROR",
            )
            return "missing"
        ctx.log("skill", f"check_tool: {tool.name!r} mounted ({np.linalg.norm(measured):.2f} N)")
        return "mounted"
