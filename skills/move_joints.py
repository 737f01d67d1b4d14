"""`move_joints`: a synchronized joint-space move, e.g. to home."""

from __future__ import annotations

from typing import TYPE_CHECKING, ClassVar, Literal

import numpy as np
from pydantic import Field, PositiveFloat

from .base import Skill, SkillParams
from .trajectory import Profile

if TYPE_CHECKING:
    from orchestrator.engine.context import Context

__all__ = ["MoveJoints"]


class MoveJointsParams(SkillParams):
    to: Literal["home"] | list[float] = Field(
        default="home", description="`home` or the arm joint angles [rad]."
    )
    max_speed: PositiveFloat = Field(
        default=1.0,
        le=2.5,
        description="[rad/s], of the joint moving furthest; lowered so that no joint exceeds "
        "0.85 of its datasheet velocity limit",
    )
    max_accel: PositiveFloat = Field(
        default=3.0,
        le=20.0,
        description="[rad/s^2], of the joint moving furthest; lowered so that no joint exceeds "
        "0.7 of its datasheet acceleration limit",
    )
    tolerance_rad: PositiveFloat = Field(default=0.005, description="[rad]")
    settle_s: PositiveFloat = Field(default=1.0, description="[s]")


class MoveJoints(Skill):
    """Move every arm joint to `to` on one jerk-limited timing law: `reached` or `timeout`."""

    name: ClassVar[str] = "move_joints"
    Params: ClassVar[type[SkillParams]] = MoveJointsParams
    outcomes: ClassVar[tuple[str, ...]] = ("reached", "timeout")

    params: MoveJointsParams

    def start(self, ctx: Context) -> None:
        p = self.params
        goal = ctx.world.home if p.to == "home" else np.asarray(p.to, float)
        if goal.shape != (ctx.robot.n_arm,):
            from orchestrator.exceptions import SkillError

            raise SkillError(
                f"move_joints: `to` needs {ctx.robot.n_arm} joint angles, got {goal.size}"
            )
        self.goal = goal
        self.profile: Profile | None = None
        # The profile starts from rest: a setpoint still moving (a move before that ended
        # without waiting to be still) is first brought to rest, as the arm can follow. Started
        # from where it was, at rest, the setpoint's velocity stepped by what it still had:
        # joint 3 at 2.1x its acceleration limit for a step (stack, seed 2, HOME).
        ctx.controller.hold_setpoint()

    def _plan(self, ctx: Context) -> None:
        p = self.params
        self.q0 = ctx.controller.q_d.copy()
        if p.to == "home" and ctx.robot.mobile:  # the arm's home: the base stays where it is
            self.goal = self.goal.copy()
            self.goal[: len(ctx.robot.base_joints)] = self.q0[: len(ctx.robot.base_joints)]
        self.delta = self.goal - self.q0
        dist = float(np.max(np.abs(self.delta)))
        speed, accel = self._within_datasheet(ctx, dist)
        self.profile = Profile(dist, speed, accel)
        self.t0 = ctx.clock

    def _within_datasheet(self, ctx: Context, dist: float) -> tuple[float, float]:
        """The profile's speed and acceleration [rad/s, rad/s^2]: `max_speed` and `max_accel`,
        lowered (and logged) where a joint would be commanded past the limits every joint
        command keeps (the IK's joint limiter: `COMMAND_MARGIN` of the velocity limits,
        `ACCELERATION_MARGIN` of the acceleration limits). Joint i covers |delta_i| / dist of
        the profile, so it moves at that share of the profile's speed and acceleration."""
        p = self.params
        share = np.abs(self.delta) / dist if dist > 0.0 else np.zeros_like(self.delta)
        moving = share > 0.0
        if not moving.any():
            return p.max_speed, p.max_accel
        limiter = ctx.ik.limiter
        speed = min(p.max_speed, float(np.min(limiter.v_max[moving] / share[moving])))
        accel = min(p.max_accel, float(np.min(limiter.a_max[moving] / share[moving])))
        if speed < p.max_speed or accel < p.max_accel:
            ctx.log(
                "skill",
                f"move_joints: max_speed {p.max_speed:g} rad/s, max_accel {p.max_accel:g} rad/s^2 "
                f"lowered to {speed:.3g} rad/s, {accel:.3g} rad/s^2: the joints' limits for "
                "commands (their datasheet limits less the margins the IK's commands keep)",
                level="WARN",
            )
        return speed, accel

    def step(self, ctx: Context) -> str | None:
        if self.profile is None:
            if np.any(ctx.controller.qd_d):
                return None  # still coming to rest
            self._plan(ctx)
        assert self.profile is not None
        elapsed = ctx.clock - self.t0
        # the profile's acceleration too: the controller integrates the setpoint along it
        # until the next tick (without it the velocity rose in a staircase, one step a tick)
        s, sd, sdd = self.profile.state(elapsed)
        ctx.controller.set_joint_target(self.q0 + s * self.delta, sd * self.delta, sdd * self.delta)
        if elapsed < self.profile.duration:
            return None
        if float(np.max(np.abs(ctx.q - self.goal))) <= self.params.tolerance_rad:
            return "reached"
        if elapsed > self.profile.duration + self.params.settle_s:
            return "timeout"
        return None
