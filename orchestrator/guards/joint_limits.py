"""`joint_limits`: every arm joint inside its range (minus a margin)."""

from __future__ import annotations

from typing import TYPE_CHECKING, ClassVar

import numpy as np
from pydantic import Field, NonNegativeFloat

from .base import Envelope, Guard, GuardParams, Violation

if TYPE_CHECKING:
    from ..engine.context import Context

__all__ = ["JointLimits"]


class JointLimitsParams(GuardParams):
    margin_rad: NonNegativeFloat = Field(
        default=0.0, description="Fire this far inside the model's joint range [rad]."
    )


class JointLimits(Guard):
    """Fires when an arm joint leaves [lower + margin, upper - margin]."""

    name: ClassVar[str] = "joint_limits"
    Params: ClassVar[type[GuardParams]] = JointLimitsParams
    ease_tolerance: ClassVar[float] = 0.002
    ease_unit: ClassVar[str] = "rad"

    params: JointLimitsParams

    def bind(self, ctx: Context) -> None:
        m, w = ctx.model, ctx.world
        jids = [m.joint(j).id for j in ctx.robot.arm_joints]
        self.lower = m.jnt_range[jids, 0] + self.params.margin_rad
        self.upper = m.jnt_range[jids, 1] - self.params.margin_rad
        self.idx = w.arm_qpos_index
        self.names = ctx.robot.arm_joints
        # check() runs every physics step: plain floats beat a few small numpy operations
        self._bounds = list(zip(self.lower.tolist(), self.upper.tolist(), strict=True))
        self._q = ctx.data.qpos[self.idx] if isinstance(self.idx, slice) else None

    def check(self, ctx: Context) -> Violation | None:
        q_now = self._q if self._q is not None else ctx.data.qpos[self.idx]
        for q, (lo, hi) in zip(q_now.tolist(), self._bounds, strict=True):
            if q < lo or q > hi:
                break
        else:  # NaN compares false: divergence is the runner's to report, not a violation
            return None
        q = ctx.data.qpos[self.idx]
        i = int(np.argmax(np.maximum(self.lower - q, q - self.upper)))
        bound = self.lower[i] if q[i] < self.lower[i] else self.upper[i]
        return Violation(
            self.name,
            f"{self.names[i]} at {q[i]:.4f} rad is outside its range",
            round(float(q[i]), 6),
            round(float(bound), 6),
        )

    def envelope(self, ctx: Context) -> Envelope | None:
        if self._q is None:
            return None
        return Envelope(bounds=((self._q, self.lower, self.upper),))

    def monitored(self, ctx: Context) -> tuple[float, float]:
        q = ctx.data.qpos[self.idx]
        return float(np.min(np.minimum(q - self.lower, self.upper - q))), 0.0

    def excess(self, ctx: Context) -> np.ndarray:
        """How far each joint is below its lower and above its upper bound [rad]. Shape
        (2 n_arm,)."""
        q = ctx.data.qpos[self.idx]
        return np.concatenate([self.lower - q, q - self.upper])
