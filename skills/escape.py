"""`escape`: where to back the arm off to — out of what it touches, back inside the workspace."""

from __future__ import annotations

from typing import TYPE_CHECKING, ClassVar

import numpy as np
from pydantic import Field, NonNegativeFloat, PositiveFloat

from orchestrator.world.pose import Pose

from .base import Skill, SkillParams

if TYPE_CHECKING:
    from orchestrator.engine.context import Context

__all__ = ["Escape"]


class EscapeParams(SkillParams):
    into: str = Field(default="escape_to", description="Blackboard key the pose is written to.")
    clearance_m: PositiveFloat = Field(
        default=0.03, le=0.2, description="How far to back off from what the arm touches [m]."
    )
    margin_m: NonNegativeFloat = Field(
        default=0.02, le=0.2, description="How far inside the workspace box to come back [m]."
    )
    force_n: PositiveFloat = Field(
        default=20.0,
        le=1000.0,
        description="A wrist force above this counts as pressing on something: back off along "
        "it [N].",
    )


class Escape(Skill):
    """Find the way out for a recovery: a TCP pose, orientation kept, `clearance_m` away from
    every contact of the arm (a link with anything; a finger with anything but a free object,
    which fingers may hold) along the contacts' normals, and along the measured wrist force
    when it exceeds `force_n` (what the hand presses on pushes it away); then moved inside the
    box of the scenario's `workspace` guard by `margin_m`.

    Outcomes: `clear` (nothing touched, nothing pressed, the TCP inside the box: the TCP's own
    pose is written to `into`), `out` (the pose to back off to is in `into`).
    """

    name: ClassVar[str] = "escape"
    Params: ClassVar[type[SkillParams]] = EscapeParams
    outcomes: ClassVar[tuple[str, ...]] = ("clear", "out")
    writes: ClassVar[dict[str, str]] = {"into": "pose"}

    params: EscapeParams

    def step(self, ctx: Context) -> str | None:
        import mujoco

        p = self.params
        tcp = ctx.tcp_pos.copy()
        away = _away_from_contacts(ctx)
        force = ctx.wrist_force()
        pressed = float(np.linalg.norm(force)) > p.force_n
        if pressed:
            away = away + force / np.linalg.norm(force)
        goal = tcp.copy()
        touching = bool(np.any(away))
        if touching:
            goal += p.clearance_m * away / np.linalg.norm(away)
        box = ctx.workspace_box
        outside = box is not None and bool(np.any(tcp < box[0]) or np.any(tcp > box[1]))
        if box is not None:
            lo, hi = box[0] + p.margin_m, box[1] - p.margin_m
            goal = np.clip(goal, np.minimum(lo, hi), np.maximum(lo, hi))
        quat = np.zeros(4)
        mujoco.mju_mat2Quat(quat, ctx.tcp_rot.flatten())
        ctx.blackboard[p.into] = Pose(pos=goal.tolist(), quat=quat.tolist())
        if not (touching or outside):
            ctx.log("skill", "escape: clear (no contact, no force, inside the workspace)")
            return "clear"
        ctx.log(
            "skill",
            f"escape: from {np.round(tcp, 4).tolist()} to {np.round(goal, 4).tolist()}"
            f" (contact: {touching}, pressed: {pressed}, outside the workspace: {outside})",
        )
        return "out"


def _away_from_contacts(ctx: Context) -> np.ndarray:
    """Sum of the unit normals of the arm's contacts, each pointing away from what it touches
    (zero without contact). A finger on a free object is not counted: it may hold it."""
    world, m, d = ctx.world, ctx.model, ctx.data
    robot, fingers = world.robot_geoms, world.finger_geoms
    held = {h.body_id for h in world.objects.values()}
    out = np.zeros(3)
    for i in range(d.ncon):
        g1, g2 = int(d.contact.geom[i][0]), int(d.contact.geom[i][1])
        if (g1 in robot) == (g2 in robot):
            continue  # the robot with itself, or two scene bodies
        mine, other, sign = (g1, g2, -1.0) if g1 in robot else (g2, g1, 1.0)
        if mine in fingers and int(m.geom_bodyid[other]) in held:
            continue
        out += sign * d.contact.frame[i][:3]  # the normal points from geom 1 to geom 2
    return out
