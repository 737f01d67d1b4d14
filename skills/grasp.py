"""`grasp`: close the gripper on an object and check that it is held."""

from __future__ import annotations

from typing import TYPE_CHECKING, ClassVar

import numpy as np
from pydantic import Field, PositiveFloat

from .base import GRIPPED_OBJECT, Skill, SkillParams
from .gripper import ANY_OBJECT, finger_contact_forces, gripped_object

if TYPE_CHECKING:
    from orchestrator.engine.context import Context

__all__ = ["Grasp"]


_STILL_MPS = 0.005
"""Finger speed below which the fingers count as stopped [m/s] (contacts creep slowly)."""


class GraspParams(SkillParams):
    object: str = Field(
        description="Name of the scene object to grasp (`*`: whichever the fingers close on).",
        json_schema_extra=GRIPPED_OBJECT,
    )
    min_force_n: PositiveFloat = Field(
        default=5.0, description="Normal force each finger must press with for `grasped` [N]."
    )
    settle_s: PositiveFloat = Field(
        default=0.1, description="Minimum closing time before the check [s]."
    )
    close_timeout_s: PositiveFloat = Field(
        default=1.5, description="Longest time to wait for the fingers to stop [s]."
    )


class Grasp(Skill):
    """Close the fingers until they stop and squeeze with the hand's force; `grasped` only if
    the object is between them and both fingers press on it with at least `min_force_n`,
    else `missed`."""

    name: ClassVar[str] = "grasp"
    Params: ClassVar[type[SkillParams]] = GraspParams
    outcomes: ClassVar[tuple[str, ...]] = ("grasped", "missed")

    params: GraspParams

    def start(self, ctx: Context) -> None:
        if self.params.object != ANY_OBJECT:
            ctx.object_handle(self.params.object)  # an unknown name stops the run here
        self.t0 = ctx.clock
        self.still_ticks = 0
        ctx.controller.hold_setpoint()
        ctx.set_gripper(0.0)

    def step(self, ctx: Context) -> str | None:
        p = self.params
        elapsed = ctx.clock - self.t0
        finger_speed = float(np.max(np.abs(ctx.data.qvel[ctx.world.robot_dof[ctx.robot.n_arm :]])))
        self.still_ticks = self.still_ticks + 1 if finger_speed < _STILL_MPS else 0
        closed = self.still_ticks >= 3 and ctx.gripper_commanded  # stopped, and squeezing
        if elapsed < p.settle_s or (not closed and elapsed < p.close_timeout_s):
            return None
        name = gripped_object(ctx, p.object)
        if name is None:
            ctx.log("skill", f"grasp: width {ctx.gripper_width * 1000:.1f} mm, no object in it")
            return "missed"
        left, right = finger_contact_forces(ctx, ctx.object_handle(name).geom_id)
        between = _between_fingers(ctx, name)
        held = min(left, right) >= p.min_force_n and between
        ctx.log(
            "skill",
            f"grasp: width {ctx.gripper_width * 1000:.1f} mm, finger forces "
            f"{left:.1f}/{right:.1f} N, between fingers: {between}",
        )
        return "grasped" if held else "missed"

    def stop(self, ctx: Context) -> None:
        ctx.controller.hold_setpoint()


def _between_fingers(ctx: Context, name: str) -> bool:
    """The object's centre lies between the finger pads (in the hand's frame)."""
    obj = np.asarray(ctx.object_pose(name).pos)
    rel = ctx.tcp_rot.T @ (obj - ctx.tcp_pos)
    half = ctx.world.objects[name].half_size
    # closing axis is the TCP y axis; along x and z the centre must be within the pad span
    return bool(abs(rel[0]) < max(half) + 0.01 and abs(rel[2]) < max(half) + 0.02)
