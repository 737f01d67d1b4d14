"""`escape`: where to back the arm off to — out of what it touches, back inside the workspace,
its joints back inside their ranges."""

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
    joints_into: str = Field(
        default="unwind_to",
        description="Blackboard key the arm joint angles to turn back to are written to.",
    )
    joint_margin_rad: PositiveFloat = Field(
        default=0.02,
        le=0.2,
        description="How far inside its range a joint past it is turned back [rad].",
    )


class Escape(Skill):
    """Find the way out for a recovery: a TCP pose, orientation kept, `clearance_m` away from
    every contact of the arm (a link with anything; a finger with anything but a free object,
    which fingers may hold) along the contacts' normals, and along the measured wrist force
    when it exceeds `force_n` (what the hand presses on pushes it away); then moved inside the
    box of the scenario's `workspace` guard by `margin_m`. Once nothing is touched or pressed
    and the TCP is inside, the joints: each arm joint past its range (the model's, narrowed by
    the `margin_rad` of the scenario's `joint_limits` guard: the controlled stop that ends a
    joint-limit abort overshoots the limit) turned back `joint_margin_rad` inside it, the
    others kept (turned first, a joint could press the hand into what it touches).

    Outcomes: `out` (the pose to back off to is in `into`), `joints` (free, but a joint is past
    its range: the joint angles to turn back to are in `joints_into`), `clear` (nothing
    touched, nothing pressed, the TCP inside the box, every joint within its range: the TCP's
    own pose is written to `into`).
    """

    name: ClassVar[str] = "escape"
    Params: ClassVar[type[SkillParams]] = EscapeParams
    outcomes: ClassVar[tuple[str, ...]] = ("clear", "out", "joints")
    writes: ClassVar[dict[str, str]] = {"into": "pose", "joints_into": "list"}

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
            unwind = _unwound(ctx, p.joint_margin_rad)
            if unwind is not None:
                q, goal, past = unwind
                ctx.blackboard[p.joints_into] = goal.tolist()
                turn = f"{np.round(q, 4).tolist()} back to {np.round(goal, 4).tolist()}"
                ctx.log("skill", f"escape: joints {past} past their range: turning {turn}")
                return "joints"
            ctx.log("skill", "escape: clear (no contact, no force, inside the workspace)")
            return "clear"
        ctx.log(
            "skill",
            f"escape: from {np.round(tcp, 4).tolist()} to {np.round(goal, 4).tolist()}"
            f" (contact: {touching}, pressed: {pressed}, outside the workspace: {outside})",
        )
        return "out"


def _unwound(ctx: Context, margin: float) -> tuple[np.ndarray, np.ndarray, list[str]] | None:
    """The arm's joint angles, the same with every joint past its range turned `margin` back
    inside it, and the names of those joints (None: every joint is within its range)."""
    world, m = ctx.world, ctx.model
    names = list(ctx.robot.arm_joints)
    jids = [m.joint(j).id for j in names]
    guard = _joint_limits_margin(getattr(world, "scenario", None))
    lower, upper = m.jnt_range[jids, 0] + guard, m.jnt_range[jids, 1] - guard
    q = np.asarray(ctx.data.qpos[world.arm_qpos_index], float).copy()
    past = (q < lower) | (q > upper)
    if not np.any(past):
        return None
    inner_lo = np.minimum(lower + margin, (lower + upper) / 2.0)
    inner_hi = np.maximum(upper - margin, (lower + upper) / 2.0)
    goal = np.where(past, np.clip(q, inner_lo, inner_hi), q)
    return q, goal, [n for n, out in zip(names, past.tolist(), strict=True) if out]


def _joint_limits_margin(scenario: object) -> float:
    """The largest `margin_rad` of the scenario's `joint_limits` guards (0: none; every task
    is watched by one with the model's range)."""
    guards = getattr(scenario, "guards", None) or {}
    entries = list(guards.items()) if isinstance(guards, dict) else [
        item for ref in guards if isinstance(ref, dict) for item in ref.items()
    ]  # fmt: skip
    margins = [float((params or {}).get("margin_rad", 0.0)) for name, params in entries
               if name == "joint_limits" and isinstance(params or {}, dict)]  # fmt: skip
    return max([0.0, *margins])


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
