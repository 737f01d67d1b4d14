"""`grasp_lost`: an object held when the guard became active stays in the grip."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, ClassVar

from pydantic import Field, PositiveFloat

from .base import Envelope, Guard, GuardParams, Violation

if TYPE_CHECKING:
    from ..engine.context import Context

__all__ = ["GraspLost"]


class GraspLostParams(GuardParams):
    tolerance_m: PositiveFloat = Field(
        default=0.005,
        le=0.1,
        description="How much further than on activation the fingers may close [m].",
    )


class GraspLost(Guard):
    """Fires when the fingers close `tolerance_m` further than the width they held when the
    guard became active: what they held has slipped out (as a gripper's own grasp check
    does). Declare it on the states that carry an object (`guards: [grasp_lost]`)."""

    name: ClassVar[str] = "grasp_lost"
    Params: ClassVar[type[GuardParams]] = GraspLostParams

    params: GraspLostParams

    def bind(self, ctx: Context) -> None:
        self._fingers = ctx.data.qpos[ctx.world.finger_qpos[0] : ctx.world.finger_qpos[-1] + 1]
        # [m] of gap per unit of the joints' sum (1 for two slide fingers; a revolute jaw's
        # radius for one: robots/base.py `finger_m_per_unit`)
        self._scale = ctx.robot.finger_m_per_unit * 2.0 / len(self._fingers)
        self._min = 0.0

    def activate(self, ctx: Context) -> None:
        self._held = float(sum(self._fingers.tolist())) * self._scale
        self._min = self._held - self.params.tolerance_m

    def check(self, ctx: Context) -> Violation | None:
        width = sum(self._fingers.tolist()) * self._scale
        if width >= self._min:
            return None
        return Violation(
            self.name,
            f"the fingers closed to {width * 1000:.1f} mm (held {self._held * 1000:.1f} mm on "
            "entering): the object slipped out",
            round(width, 5),
            round(self._min, 5),
        )

    def envelope(self, ctx: Context) -> Envelope:
        # both fingers at least half the smallest width: their sum is at least the width
        # (halving is exact, and rounding a sum never takes it below an exact bound)
        n = len(self._fingers)
        half = self._min / (n * self._scale)
        return Envelope(bounds=((self._fingers, [half] * n, [math.inf] * n),))

    def monitored(self, ctx: Context) -> tuple[float, float]:
        return float(sum(self._fingers.tolist())) * self._scale, self._min
