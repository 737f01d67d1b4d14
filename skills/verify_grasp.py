"""`verify_grasp`: check that an object is really held (after a lift, it came along)."""

from __future__ import annotations

from typing import TYPE_CHECKING, ClassVar

import numpy as np
from pydantic import Field, PositiveFloat

from orchestrator.world.randomization import object_poses

from .base import GRIPPED_OBJECT, Skill, SkillParams
from .gripper import ANY_OBJECT, finger_contact_forces, grasped_height, gripped_object

if TYPE_CHECKING:
    from orchestrator.engine.context import Context

__all__ = ["VerifyGrasp"]


class VerifyGraspParams(SkillParams):
    object: str = Field(
        description="Name of the scene object that should be held (`*`: any one).",
        json_schema_extra=GRIPPED_OBJECT,
    )
    min_force_n: PositiveFloat = Field(
        default=5.0, description="Normal force each finger must still press with [N]."
    )
    max_offset_m: PositiveFloat = Field(
        default=0.02, description="Largest distance of the object's centre from the TCP [m]."
    )
    min_height_m: float = Field(
        default=0.02,
        description="The object must be at least this far above where it lay when the "
        "fingers closed on it (else where it started: the table, the floor) [m].",
    )
    duration_s: PositiveFloat = Field(
        default=0.05, description="How long the check must hold continuously [s]."
    )


class VerifyGrasp(Skill):
    """`held` if, for `duration_s`, both fingers press on the object, its centre stays within
    `max_offset_m` of the TCP and it is `min_height_m` above where it lay when the fingers
    closed on it (a block pushed off a desk is lifted from the floor); `dropped` as soon as
    any fails."""

    name: ClassVar[str] = "verify_grasp"
    Params: ClassVar[type[SkillParams]] = VerifyGraspParams
    outcomes: ClassVar[tuple[str, ...]] = ("held", "dropped")

    params: VerifyGraspParams

    def start(self, ctx: Context) -> None:
        if self.params.object != ANY_OBJECT:
            ctx.object_handle(self.params.object)  # an unknown name stops the run here
        # the lift is measured from where each object started (a table, a shelf, the floor)
        self.rest_z = {
            name: float(pos[2]) for name, pos, _ in object_poses(ctx.scenario, ctx.world.seed)
        }
        self.t0 = ctx.clock
        ctx.controller.hold_setpoint()

    def step(self, ctx: Context) -> str | None:
        p = self.params
        name = gripped_object(ctx, p.object)
        if name is None:
            ctx.log("skill", "verify_grasp: not held (no object between the fingers)")
            return "dropped"
        handle = ctx.object_handle(name)
        left, right = finger_contact_forces(ctx, handle.geom_id)
        pos = np.asarray(ctx.object_pose(name).pos)
        offset = float(np.linalg.norm(pos - ctx.tcp_pos))
        rest = grasped_height(ctx, name)  # where it lay when the fingers closed on it
        lifted = pos[2] - (self.rest_z[name] if rest is None else rest) >= p.min_height_m
        if min(left, right) < p.min_force_n or offset > p.max_offset_m or not lifted:
            ctx.log(
                "skill",
                f"verify_grasp: not held (forces {left:.1f}/{right:.1f} N, offset "
                f"{offset * 1000:.1f} mm, lifted {lifted})",
            )
            return "dropped"
        return "held" if ctx.clock - self.t0 >= p.duration_s else None

    def stop(self, ctx: Context) -> None:
        # The setpoint may still be coming to rest from the lift (`start`'s hold_setpoint):
        # the default stop, a hold at the measured joints, would step its velocity to zero
        # and the damping kick the arm (pick_place_so101's wrist at 1.3x its acceleration
        # limit as TRANSPORT took over, seed 2). Keep bringing it to rest instead.
        ctx.controller.hold_setpoint()
