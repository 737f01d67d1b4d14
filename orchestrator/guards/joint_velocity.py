"""`joint_velocity`: no arm joint moves faster than its limit (overspeed)."""

from __future__ import annotations

from typing import TYPE_CHECKING, ClassVar

import numpy as np
from pydantic import Field, PositiveFloat

from .base import Envelope, Guard, GuardParams, Violation
from .per_joint import arm_view, envelope_bounds, first_beyond, resolve_limits

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

    @classmethod
    def robot_problems(cls, params: GuardParams, robot: type) -> list[tuple[str, str]]:
        p = cls.Params.model_validate(params)
        assert isinstance(p, JointVelocityParams)
        n = len(robot.arm_joints)  # type: ignore[attr-defined]
        if p.limits_rad_s is not None and len(p.limits_rad_s) != n:
            return [
                (
                    "limits_rad_s",
                    f"limits_rad_s needs {n} values (one per arm joint), got {len(p.limits_rad_s)}",
                )
            ]
        return []

    def bind(self, ctx: Context) -> None:
        self._lim = resolve_limits(
            self.params.limits_rad_s,
            ctx.robot.joint_velocity_limits().tolist(),
            self.params.scale,
            "limits_rad_s",
            "rad/s",
        )
        self._dofs = ctx.world.arm_dof
        self._qd = arm_view(ctx.data.qvel, self._dofs)

    def check(self, ctx: Context) -> Violation | None:
        qd = (self._qd if self._qd is not None else ctx.data.qvel[self._dofs]).tolist()
        i = first_beyond(qd, self._lim)
        if i is None:
            return None
        v, lim = qd[i], self._lim[i]
        return Violation(
            self.name,
            f"joint {i + 1} at {v:.3f} rad/s exceeds its limit {lim:.3f} rad/s",
            round(v, 5),
            round(lim, 5),
        )

    def envelope(self, ctx: Context) -> Envelope | None:
        if self._qd is None:
            return None
        return Envelope(bounds=((self._qd, *envelope_bounds(self._lim)),))

    def monitored(self, ctx: Context) -> tuple[float, float]:
        qd = np.abs(ctx.data.qvel[self._dofs]) / np.asarray(self._lim)
        return float(np.max(qd)), 1.0

    def excess(self, ctx: Context) -> np.ndarray:
        """Each joint's speed above its limit [rad/s]. Shape (n_arm,)."""
        return np.abs(ctx.data.qvel[self._dofs]) - np.asarray(self._lim)
