"""`grasp`: close the gripper and check, by the fingers, what it holds."""

from __future__ import annotations

from typing import TYPE_CHECKING, ClassVar

import numpy as np
from pydantic import Field, PositiveFloat

from .base import GRIPPED_OBJECT, Skill, SkillParams
from .gripper import ANY_OBJECT, held_object, note_grasp

if TYPE_CHECKING:
    from orchestrator.engine.context import Context

__all__ = ["Grasp"]


_STILL_MPS = 0.005
"""Finger speed below which the fingers count as stopped [m/s] (contacts creep slowly)."""


class GraspParams(SkillParams):
    object: str = Field(
        description="Name of the scene object that should end up in the hand (`*`: whichever "
        "the fingers close on).",
        json_schema_extra=GRIPPED_OBJECT,
    )
    min_force_n: PositiveFloat = Field(
        default=5.0, description="Normal force each finger must press with for `grasped` [N]."
    )
    min_width_m: PositiveFloat = Field(
        default=0.005,
        le=0.2,
        description="Narrowest gap between the stopped fingers that can be an object in the "
        "hand [m]: closer, they closed on nothing (or pinch an edge).",
    )
    settle_s: PositiveFloat = Field(
        default=0.1, description="Minimum closing time before the check [s]."
    )
    close_timeout_s: PositiveFloat = Field(
        default=1.5, description="Longest time to wait for the fingers to stop [s]."
    )
    into: str | None = Field(
        default=None,
        description="Blackboard key the name of the object in the hand is written to (when "
        "the fingers hold one).",
    )


class Grasp(Skill):
    """Close the fingers until they stop and squeeze with the hand's force, then judge what
    the hand holds the way a gripper does: the fingers stopped at a plausible width
    (`min_width_m` or more) with both pads pressing on one object with at least
    `min_force_n`, its centre between the pads — whichever object it is.

    Outcomes: `grasped` (it holds `object`, or any one for `*`), `missed` (nothing held),
    `wrong_object` (it holds another object than `object`: the log and the transition's
    detail name it). The held object's name goes to `into`.
    """

    name: ClassVar[str] = "grasp"
    Params: ClassVar[type[SkillParams]] = GraspParams
    outcomes: ClassVar[tuple[str, ...]] = ("grasped", "missed", "wrong_object")
    writes: ClassVar[dict[str, str]] = {"into": "str"}

    params: GraspParams

    def start(self, ctx: Context) -> None:
        if self.params.object != ANY_OBJECT:
            ctx.object_handle(self.params.object)  # an unknown name stops the run here
        self.t0 = ctx.clock
        self.still_ticks = 0
        self.verdict = ""
        ctx.controller.hold_setpoint()
        touch = _touch_from(ctx, self.params.object)
        self.touch, self.half = touch if touch is not None else (None, 0.0)
        """Each finger's opening where the closing slows (None: no slow stretch), and where
        the fingers hold the object [m]."""
        ctx.set_gripper(0.0 if self.touch is None else self.touch)

    def _close(self, ctx: Context) -> None:
        """The slow stretch: the commanded opening goes down at the robot's touch speed from
        `touch` until the fingers press on something (then, or past the object, the whole
        grip: 0)."""
        assert self.touch is not None
        speed = ctx.robot.grip_touch_speed_mps
        assert speed is not None
        target = ctx.gripper_target
        if 0.5 * ctx.gripper_width > target + _TOUCH_LAG_M:
            return  # still on the way there at the gripper's speed
        if held_object(ctx)[0] is not None or target <= self.half - _PAST_M:
            self.touch = None
            ctx.set_gripper(0.0)
            return
        # never more than `_PUSH_LEAD_M` ahead of the fingers: one finger pushing the object
        # over to the other (the search put it off the TCP) pushes with the drive's moving
        # force, it is not taken for a grasp and squeezed along the table
        lead = 0.5 * ctx.gripper_width - _PUSH_LEAD_M
        ctx.set_gripper(max(target - speed * ctx.dt_control, lead, 0.0))

    def step(self, ctx: Context) -> str | None:
        p = self.params
        if self.touch is not None:
            self._close(ctx)
        elapsed = ctx.clock - self.t0
        finger_dof = ctx.world.robot_dof[ctx.robot.n_arm :]
        finger_speed = float(np.max(np.abs(ctx.data.qvel[finger_dof]))) * (
            ctx.robot.finger_m_per_unit  # [m/s] of opening (a revolute jaw's: robots/base.py)
        )
        self.still_ticks = self.still_ticks + 1 if finger_speed < _STILL_MPS else 0
        closed = self.still_ticks >= 3 and ctx.gripper_commanded  # stopped, and squeezing
        if elapsed < p.settle_s or (not closed and elapsed < p.close_timeout_s):
            return None
        width = ctx.gripper_width
        name, left, right = held_object(ctx)
        between = name is not None and _between_fingers(ctx, name)
        held = (
            name is not None
            and width >= p.min_width_m
            and min(left, right) >= p.min_force_n
            and between
        )
        figures = f"width {width * 1000:.1f} mm, finger forces {left:.1f}/{right:.1f} N"
        if not held:
            self.verdict = f"{figures}: nothing held" + (
                f" ({name} touched, between fingers: {between})" if name else ""
            )
            ctx.log("skill", f"grasp: {self.verdict}")
            return "missed"
        assert name is not None
        note_grasp(ctx, name)
        if p.into is not None:
            ctx.blackboard[p.into] = name
        if p.object not in (ANY_OBJECT, name):
            self.verdict = f"holding {name}, not {p.object} ({figures})"
            ctx.log("skill", f"grasp: {self.verdict}", level="WARN")
            return "wrong_object"
        ctx.log("skill", f"grasp: holding {name} ({figures})")
        return "grasped"

    def stop(self, ctx: Context) -> None:
        ctx.controller.hold_setpoint()

    def explain(self, ctx: Context) -> str | None:
        return self.verdict or None


_TOUCH_LAG_M = 0.0005
"""The fingers count as at the start of the slow stretch this close to it [m]."""
_PUSH_LEAD_M = 0.0015
"""Farthest the slow stretch's command runs ahead of the fingers [m]: within the 2 mm short
of its target at which the hand's drive takes a held-back finger for one that grasps and
squeezes with the whole grip force (robots/hand.py)."""
_PAST_M = 0.002
"""How far past the object's expected half-width the slow stretch goes on without a touch
before the whole grip is commanded [m]."""


def _touch_from(ctx: Context, name: str) -> tuple[float, float] | None:
    """Each finger's opening where the closing on `name` slows, and its half-width across
    the fingers (where they hold it) [m]. It slows at the farther of its faces
    across the fingers from the TCP (its half-width plus its centre's offset along the
    closing axis: the search's noise puts it off the TCP) plus the robot's
    `grip_touch_from_m`, or where the fingers are if that is farther (None: the robot
    closes at one speed, the object is `*`, or the fingers are already at it). The object's
    pose and size as the grasp's own check reads them (`_between_fingers`)."""
    robot = ctx.robot
    if robot.grip_touch_speed_mps is None or name == ANY_OBJECT:
        return None
    handle = ctx.world.objects[name]
    rot = ctx.data.xmat[handle.body_id].reshape(3, 3)  # object frame -> world
    closing = ctx.tcp_rot[:, 1]
    across = rot.T @ closing  # the closing axis in the object's frame
    half = float(np.abs(across) @ handle.half_size)
    offset = abs(float(closing @ (ctx.data.xpos[handle.body_id] - ctx.tcp_pos)))
    touch = half + offset + robot.grip_touch_from_m
    opening = 0.5 * ctx.gripper_width
    if half + _PAST_M >= opening:
        return None  # the fingers are already at the object
    return min(touch, opening), half


def _between_fingers(ctx: Context, name: str) -> bool:
    """The object's centre lies between the finger pads (in the hand's frame)."""
    obj = np.asarray(ctx.object_pose(name).pos)
    rel = ctx.tcp_rot.T @ (obj - ctx.tcp_pos)
    half = ctx.world.objects[name].half_size
    # closing axis is the TCP y axis; along x and z the centre must be within the pad span
    return bool(abs(rel[0]) < max(half) + 0.01 and abs(rel[2]) < max(half) + 0.02)
