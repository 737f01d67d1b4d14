"""`joint_torque`: no arm joint is commanded near its torque limit for long."""

from __future__ import annotations

from typing import TYPE_CHECKING, ClassVar

import numpy as np
from pydantic import Field, PositiveFloat

from .base import Envelope, Guard, GuardParams, Violation

if TYPE_CHECKING:
    from ..engine.context import Context

__all__ = ["JointTorque"]


class JointTorqueParams(GuardParams):
    fraction: float = Field(
        default=0.9, gt=0.0, le=1.0, description="Of each joint's torque limit."
    )
    duration_ms: PositiveFloat = Field(
        default=20.0, le=1e5, description="How long the torque may stay above it [ms]."
    )


class JointTorque(Guard):
    """Fires when the torque commanded to an arm joint stays at or above `fraction` of its
    limit for `duration_ms`: the controller is fighting something it cannot move (a blocked
    or failing joint, a payload beyond the arm's capacity)."""

    name: ClassVar[str] = "joint_torque"
    Params: ClassVar[type[GuardParams]] = JointTorqueParams
    priority: ClassVar[int] = 1

    params: JointTorqueParams

    def bind(self, ctx: Context) -> None:
        self._limit = (ctx.world.arm_effort_limit * self.params.fraction).tolist()
        self._steps = max(1, round(self.params.duration_ms / 1000.0 / ctx.dt_physics))
        self._count = [0] * len(self._limit)
        self._counting = 0
        """Sum of the counts: 0 lets `check` take its fast path."""
        self._tau = ctx.controller.tau  # the controller writes its output into this array
        # `check` counts a joint at |tau| >= limit: its envelope is strictly below, the largest
        # float under the limit (computed once: the envelope is asked for at every state change)
        self._below = np.nextafter(np.asarray(self._limit), 0.0).tolist()

    def activate(self, ctx: Context) -> None:
        self._count = [0] * len(self._limit)
        self._counting = 0

    def check(self, ctx: Context) -> Violation | None:
        taus = self._tau.tolist()
        if self._counting == 0:  # the fast path: every joint below its limit, one plain loop
            for tau, lim in zip(taus, self._limit, strict=True):
                if tau >= lim or tau <= -lim:
                    break
            else:
                return None
        count = self._count
        for i, (tau, lim) in enumerate(zip(taus, self._limit, strict=True)):
            if tau >= lim or tau <= -lim:
                count[i] += 1
                self._counting += 1
                if count[i] >= self._steps:
                    return Violation(
                        self.name,
                        f"joint {i + 1} commanded {tau:.1f} Nm, at least "
                        f"{self.params.fraction:.0%} of its limit, for "
                        f"{self.params.duration_ms:g} ms",
                        round(tau, 3),
                        round(lim, 3),
                    )
            elif count[i]:
                self._counting -= count[i]
                count[i] = 0
        return None

    def envelope(self, ctx: Context) -> Envelope | None:
        if min(self._limit) <= 0.0:
            return None
        below = self._below
        return Envelope(bounds=((self._tau, [-v for v in below], below),), stateful=True)

    def settled(self) -> bool:
        return self._counting == 0

    def monitored(self, ctx: Context) -> tuple[float, float]:
        return float(np.max(np.abs(self._tau) / np.asarray(self._limit))), 1.0
