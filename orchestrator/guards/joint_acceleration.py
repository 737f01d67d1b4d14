"""`joint_acceleration`: no arm joint accelerates faster than its datasheet limit.

The reading is MuJoCo's `qacc` after the step: the acceleration the integrator applied over
the physics step just taken, the truth of the simulated arm (constraint and contact
accelerations included). A finite difference of `qvel` over the physics step reads the same to
within the implicit integrator's joint damping term (measured on pick_place seeds 0-2: at most
0.17 rad/s^2 apart on limits of 7.5-20 rad/s^2, `qacc` the larger), needs a previous reading
to be carried across steps, resets and snapshots, and cannot be bounded by an envelope:
`qacc` is a view of MjData, tested with the other guards' envelopes at no extra cost per step.

The controlled stop of an abort brakes at the safety stop's own `max_decel_rad_s2`
(docs/safety.md), above the datasheet: no guard is checked while it runs (the step loop's
safety response), which is this guard's one exemption. The gentle stop at the end of a run
brakes at half the datasheet limits and is checked like any motion.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, ClassVar

import numpy as np
from pydantic import Field, PositiveFloat

from .base import Envelope, Guard, GuardParams, Violation
from .per_joint import (
    arm_view,
    envelope_bounds,
    first_beyond,
    limit_problems,
    resolve_limits,
)

if TYPE_CHECKING:
    from ..engine.context import Context

__all__ = ["JointAcceleration"]


class JointAccelerationParams(GuardParams):
    limits_rad_s2: list[PositiveFloat] | None = Field(
        default=None,
        description="Acceleration limit per arm joint [rad/s^2], each at most the robot's "
        "datasheet limit (default: the datasheet limits).",
    )
    scale: PositiveFloat = Field(
        default=1.0,
        le=1.0,
        description="Fire at this fraction of the limits (at most 1: never above the datasheet).",
    )


class JointAcceleration(Guard):
    """Fires when an arm joint's acceleration (MuJoCo's `qacc`, every physics step) exceeds
    its limit."""

    name: ClassVar[str] = "joint_acceleration"
    Params: ClassVar[type[GuardParams]] = JointAccelerationParams
    priority: ClassVar[int] = 0
    """Below the sensor and velocity guards, with the force and position ones: an excess
    acceleration is most often the effect of a force (a push, an impact) that `contact_force`
    names as the cause when both fire on one step (the scenario lists it first)."""
    ease_tolerance: ClassVar[float] = 1.0
    ease_unit: ClassVar[str] = "rad/s^2"

    params: JointAccelerationParams

    @classmethod
    def robot_problems(cls, params: GuardParams, robot: type) -> list[tuple[str, str]]:
        p = cls.Params.model_validate(params)
        assert isinstance(p, JointAccelerationParams)
        limits = robot.acceleration_limits  # type: ignore[attr-defined]
        return limit_problems(
            p.limits_rad_s2, limits, p.scale, "limits_rad_s2", "rad/s^2", at_most_datasheet=True
        )

    def bind(self, ctx: Context) -> None:
        self._lim = resolve_limits(
            self.params.limits_rad_s2,
            ctx.robot.acceleration_limits,
            self.params.scale,
            "limits_rad_s2",
            "rad/s^2",
            at_most_datasheet=True,
        )
        self._dofs = ctx.world.arm_dof
        self._qdd = arm_view(ctx.data.qacc, self._dofs)

    def _reading(self, ctx: Context) -> np.ndarray:
        return self._qdd if self._qdd is not None else ctx.data.qacc[self._dofs]

    def check(self, ctx: Context) -> Violation | None:
        qdd = self._reading(ctx).tolist()
        i = first_beyond(qdd, self._lim)
        if i is None:
            return None
        v, lim = qdd[i], self._lim[i]
        return Violation(
            self.name,
            f"joint {i + 1} at {v:.2f} rad/s^2 exceeds its limit {lim:.2f} rad/s^2",
            round(v, 4),
            round(lim, 4),
        )

    def envelope(self, ctx: Context) -> Envelope | None:
        if self._qdd is None:
            return None
        return Envelope(bounds=((self._qdd, *envelope_bounds(self._lim)),))

    def monitored(self, ctx: Context) -> tuple[float, float]:
        return float(np.max(np.abs(self._reading(ctx)) / np.asarray(self._lim))), 1.0

    def excess(self, ctx: Context) -> np.ndarray:
        """Each joint's acceleration above its limit [rad/s^2]. Shape (n_arm,)."""
        return np.abs(self._reading(ctx)) - np.asarray(self._lim)
