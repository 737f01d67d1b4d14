"""`joint_velocity`: no arm joint moves faster than its limit (overspeed)."""

from __future__ import annotations

from typing import TYPE_CHECKING, ClassVar

import numpy as np
from pydantic import Field, PositiveFloat

from .base import Envelope, Guard, GuardParams, Violation

if TYPE_CHECKING:
    from ..engine.context import Context

__all__ = ["JointVelocity"]


class JointVelocityParams(GuardParams):
    limits_rad_s: list[PositiveFloat] | None = Field(
        default=None,
        description="Speed limit per arm joint [rad/s] (default: the robot's datasheet limits, "
        "from its URDF).",
    )
    scale: PositiveFloat = Field(
        default=1.0, le=2.0, description="Fire at this fraction of the limits."
    )


class JointVelocity(Guard):
    """Fires when an arm joint's speed, read on its safety encoder, exceeds its limit."""

    name: ClassVar[str] = "joint_velocity"
    Params: ClassVar[type[GuardParams]] = JointVelocityParams
    priority: ClassVar[int] = 1
    ease_tolerance: ClassVar[float] = 0.05
    ease_unit: ClassVar[str] = "rad/s"

    params: JointVelocityParams

    def bind(self, ctx: Context) -> None:
        n = ctx.robot.n_arm
        limits = self.params.limits_rad_s
        if limits is None:
            limits = ctx.robot.joint_velocity_limits().tolist()
        if len(limits) != n:
            raise ValueError(
                f"limits_rad_s needs {n} values (one per arm joint), got {len(limits)}"
            )
        self._lim = [v * self.params.scale for v in limits]
        self._qd = ctx.data.qvel[ctx.world.arm_dof[0] : ctx.world.arm_dof[-1] + 1]
        if len(self._qd) != n:  # the arm's dofs are not contiguous
            self._qd = None
        self._dofs = ctx.world.arm_dof

    def check(self, ctx: Context) -> Violation | None:
        qd = (self._qd if self._qd is not None else ctx.data.qvel[self._dofs]).tolist()
        for v, lim in zip(qd, self._lim, strict=True):  # the fast path
            if v > lim or v < -lim:
                break
        else:
            return None
        for i, (v, lim) in enumerate(zip(qd, self._lim, strict=True)):
            if v > lim or v < -lim:
                return Violation(
                    self.name,
                    f"joint {i + 1} at {v:.3f} rad/s exceeds its limit {lim:.3f} rad/s",
                    round(v, 5),
                    round(lim, 5),
                )
        return None

    def envelope(self, ctx: Context) -> Envelope | None:
        if self._qd is None:
            return None
        return Envelope(bounds=((self._qd, [-v for v in self._lim], self._lim),))

    def monitored(self, ctx: Context) -> tuple[float, float]:
        qd = np.abs(ctx.data.qvel[self._dofs]) / np.asarray(self._lim)
        return float(np.max(qd)), 1.0

    def excess(self, ctx: Context) -> np.ndarray:
        """Each joint's speed above its limit [rad/s]. Shape (n_arm,)."""
        return np.abs(ctx.data.qvel[self._dofs]) - np.asarray(self._lim)
