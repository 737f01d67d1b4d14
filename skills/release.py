"""`release`: open the gripper."""

from __future__ import annotations

from typing import TYPE_CHECKING, ClassVar

import numpy as np
from pydantic import Field, PositiveFloat

from .base import Skill, SkillParams
from .gripper import held_object

if TYPE_CHECKING:
    from orchestrator.engine.context import Context

__all__ = ["Release"]

_STILL_MPS = 0.01
"""A released object slower than this is at rest [m/s]."""
_STILL_TICKS = 5
"""Control ticks it must stay that slow."""


class ReleaseParams(SkillParams):
    opening_m: PositiveFloat | None = Field(
        default=None, description="Per-finger opening [m] (default: fully open)."
    )
    timeout_s: PositiveFloat = Field(default=1.0, description="[s]")
    settle_s: float = Field(
        default=0.0,
        ge=0.0,
        le=5.0,
        description="Once the fingers are open, wait up to this long for the object they held "
        "to come to rest [s] (0: do not wait): what it does as it falls and settles is then "
        "part of this task, not of the next one.",
    )


class Release(Skill):
    """Open the fingers to `opening_m`: `released` once they are there, else `timeout`.

    With `settle_s`, `released` waits until the object the fingers held has come to rest
    (`_STILL_MPS` for `_STILL_TICKS` control ticks), at most `settle_s` after they opened: a
    parcel let fall into a bin leaned on its wall and was still toppling over 0.2 s later,
    2 cm under the next parcel's task (explore on sorting, seed 817606967).
    """

    name: ClassVar[str] = "release"
    Params: ClassVar[type[SkillParams]] = ReleaseParams
    outcomes: ClassVar[tuple[str, ...]] = ("released", "timeout")

    params: ReleaseParams

    def start(self, ctx: Context) -> None:
        self.opening = min(
            self.params.opening_m or ctx.robot.gripper_open_m, ctx.robot.gripper_open_m
        )
        self.t0 = ctx.clock
        self.held = held_object(ctx)[0] if self.params.settle_s > 0.0 else None
        """The object the fingers held as they opened (None: none, or no waiting for it)."""
        self.opened_t: float | None = None
        self.still = 0
        ctx.controller.hold_setpoint()
        ctx.set_gripper(self.opening)

    def step(self, ctx: Context) -> str | None:
        if self.opened_t is None:
            if ctx.gripper_width >= 2 * self.opening - 0.002:
                self.opened_t = ctx.clock
            elif ctx.clock - self.t0 > self.params.timeout_s:
                return "timeout"
            else:
                return None
        if self.held is None:
            return "released"
        adr = ctx.world.objects[self.held].qvel_adr
        speed = float(np.linalg.norm(ctx.data.qvel[adr : adr + 3]))
        self.still = self.still + 1 if speed < _STILL_MPS else 0
        if self.still >= _STILL_TICKS:
            return "released"
        if ctx.clock - self.opened_t >= self.params.settle_s:
            ctx.log("skill", f"release: {self.held} still moving at {speed:.3f} m/s")
            return "released"
        return None

    def stop(self, ctx: Context) -> None:
        ctx.controller.hold_setpoint()
