"""Base motions: the mobile base along straight segments between poses, arm held.

Each segment (a translation and a turn) runs on one time-optimal, jerk-limited timing law
(Ruckig): the slower of the translation's and the turn's profiles sets its duration, so the
base turns while it drives and both finish together; the base stops at each corner. The
commands stay within `COMMAND_MARGIN` of the base's speed and acceleration limits (the rest is
for the servo's tracking) and go to the controller as joint setpoints (position, velocity and
acceleration) of the base joints; the arm keeps the setpoint it had.
"""

from __future__ import annotations

import abc
import math
from typing import TYPE_CHECKING, ClassVar

import numpy as np
from orchestrator.robots.mobile import BASE
from pydantic import Field, PositiveFloat

from orchestrator.exceptions import SkillError

from .base import Skill, SkillParams
from .base_map import BaseMap
from .ik import COMMAND_MARGIN
from .trajectory import Profile

if TYPE_CHECKING:
    from orchestrator.engine.context import Context

__all__ = [
    "BaseMotion",
    "BaseMotionParams",
    "BaseMotionSkill",
    "back_out",
    "base_pose",
    "wrap_angle",
]


def wrap_angle(a: float) -> float:
    """`a` [rad] wrapped to [-pi, pi)."""
    return (a + math.pi) % (2.0 * math.pi) - math.pi


ESCAPE_MARGIN_M = 0.02
"""Clearance of the chassis from every box while it backs out of a tight spot [m] (it came in
along the same line with `approach`'s 5 cm)."""


def back_out(ctx: Context, room: BaseMap, here: np.ndarray) -> list[np.ndarray] | None:
    """The way out of a spot closer to the boxes than planned paths may start (where an
    approach left the base, by the furniture): `[]` when the base stands free, one pose
    straight out with the heading kept (`BaseMap.escape`), or None (logged) when boxed in."""
    if room.is_free(here[0], here[1]):
        return []
    rect = (BASE.length_m / 2, BASE.width_m / 2)
    out = room.escape(here[:2], float(here[2]), rect, ESCAPE_MARGIN_M)
    if out is None:
        ctx.log("skill", f"base boxed in at {np.round(here[:2], 3).tolist()}", level="WARN")
        return None
    ctx.log(
        "skill",
        f"base backs out {float(np.linalg.norm(out - here[:2])):.2f} m to "
        f"{np.round(out, 3).tolist()} before its path",
    )
    return [np.array([out[0], out[1], here[2]])]


def base_pose(ctx: Context) -> np.ndarray:
    """The base's measured pose in the world: x [m], y [m], yaw [rad] (the joint's, unwrapped).
    Shape (3,)."""
    origin = ctx.scenario.robot.base_pos
    q = ctx.q
    return np.array([q[0] + origin[0], q[1] + origin[1], q[2]])


class BaseMotion:
    """The base through world poses `(x, y, yaw)` one straight segment after another.

    Args:
        ctx: The episode context (the robot, its limits, the controller's setpoint).
        poses: The poses to pass, in order, world frame ([m], [m], [rad]); each yaw is reached
            the short way round from the previous one.
        speed: Speed limit of the translation [m/s] (capped by the base's).
        yaw_rate: Speed limit of the turn [rad/s] (capped by the base's).
        wrap_yaw: Reach each yaw the short way round; False: turn by exactly the difference.
    """

    def __init__(
        self,
        ctx: Context,
        poses: list[np.ndarray],
        speed: float,
        yaw_rate: float,
        wrap_yaw: bool = True,
    ) -> None:
        robot = ctx.robot
        vel = robot.joint_velocity_limits()
        acc = np.asarray(robot.acceleration_limits, float)
        self.v = min(speed, COMMAND_MARGIN * float(vel[0]))
        self.w = min(yaw_rate, COMMAND_MARGIN * float(vel[2]))
        self.a = COMMAND_MARGIN * float(acc[0])
        self.alpha = COMMAND_MARGIN * float(acc[2])
        jerk = COMMAND_MARGIN * np.asarray(robot.jerk_limits, float)
        self.jerk, self.yaw_jerk = float(jerk[0]), float(jerk[2])
        """The base's datasheet jerk (the profiles' default, 50 x their acceleration, was 4x
        it for the yaw: the servo overshot each jump of the commanded acceleration, up to
        1.12x the yaw's acceleration limit for 17 physics steps, mobile_search seed 4)."""
        self.origin = np.array([*ctx.scenario.robot.base_pos[:2], 0.0])
        self.q_hold = ctx.controller.q_d.copy()
        start = self.q_hold[:3].copy()
        self.segments: list[tuple[np.ndarray, np.ndarray, Profile]] = []
        prev = start
        for pose in poses:
            goal = np.asarray(pose, float) - self.origin
            if wrap_yaw:
                goal[2] = prev[2] + wrap_angle(goal[2] - prev[2])
            delta = goal - prev
            lin = Profile(float(np.hypot(delta[0], delta[1])), self.v, self.a, self.jerk)
            ang = Profile(abs(float(delta[2])), self.w, self.alpha, self.yaw_jerk)
            self.segments.append((prev, delta, lin if lin.duration >= ang.duration else ang))
            prev = goal
        self.goal = prev
        """The last pose in joint coordinates (x, y relative to the root; yaw unwrapped)."""
        self.duration = sum(p.duration for _, _, p in self.segments)
        self.path_m = sum(float(np.hypot(d[0], d[1])) for _, d, _ in self.segments)
        self._floats = [(a.tolist(), d.tolist()) for a, d, _ in self.segments]
        """Each segment's start and delta as floats: the setpoint is three sums per tick."""
        self._q = self.q_hold.copy()
        self._qd = np.zeros_like(self.q_hold)
        self._qdd = np.zeros_like(self.q_hold)
        """The setpoint sent every tick (the controller copies it): the arm's part is q_hold."""

    def command(self, ctx: Context, t: float) -> bool:
        """Send the controller the setpoint at `t` [s] from the start; True once it is over."""
        q, qd, qdd = self._q, self._qd, self._qdd
        elapsed = 0.0
        last = self.segments[-1][2] if self.segments else None
        for (_, _, profile), (start, delta) in zip(self.segments, self._floats, strict=True):
            if t < elapsed + profile.duration or profile is last:
                s, sd, sdd = profile.state(t - elapsed)
                if profile.duration <= 0.0:
                    s, sd, sdd = 1.0, 0.0, 0.0
                for i in range(3):  # floats: the same products and sums numpy would do
                    q[i] = start[i] + s * delta[i]
                    qd[i] = sd * delta[i]
                    qdd[i] = sdd * delta[i]
                break
            elapsed += profile.duration
        else:
            q[:3] = self.goal
            qd[:3] = 0.0
            qdd[:3] = 0.0
        ctx.controller.set_joint_target(q, qd, qdd)
        return t >= self.duration

    def error(self, ctx: Context) -> tuple[float, float]:
        """Distance [m] and yaw difference [rad] of the measured base from the goal."""
        q = ctx.q
        return float(np.hypot(q[0] - self.goal[0], q[1] - self.goal[1])), abs(q[2] - self.goal[2])


class BaseMotionParams(SkillParams):
    max_speed: PositiveFloat = Field(
        default=0.5, le=5.0, description="Translation speed limit [m/s] (capped by the base's)."
    )
    max_yaw_rate: PositiveFloat = Field(
        default=1.0, le=10.0, description="Turn rate limit [rad/s] (capped by the base's)."
    )
    tolerance_m: PositiveFloat = Field(default=0.01, description="Position tolerance [m].")
    tolerance_deg: PositiveFloat = Field(default=1.0, description="Yaw tolerance [deg].")
    settle_s: PositiveFloat = Field(
        default=1.0, description="Time allowed after the motion to settle within tolerance [s]."
    )


class BaseMotionSkill(Skill):
    """A skill that moves the mobile base through poses (`BaseMotion`), the arm held.

    Subclasses give the poses (`plan`: None when there is no way there). The distance the
    base really travels (measured every control tick) is added to the run's `base_travel_m`.
    """

    params: BaseMotionParams
    arrived: ClassVar[str] = "reached"
    blocked: ClassVar[str] = "blocked"
    wrap_yaw: ClassVar[bool] = True

    @abc.abstractmethod
    def plan(self, ctx: Context) -> list[np.ndarray] | None:
        """The world poses (x [m], y [m], yaw [rad]) to pass, or None if none can be found."""

    def start(self, ctx: Context) -> None:
        if not ctx.robot.mobile:
            raise SkillError(
                f"{self.name}: robot {ctx.robot.name!r} has no mobile base"
                " (valid: a robot with base joints, e.g. mobile_panda)"
            )
        p = self.params
        poses = self.plan(ctx)
        self.motion = (
            None
            if poses is None
            else BaseMotion(ctx, poses, p.max_speed, p.max_yaw_rate, self.wrap_yaw)
        )
        self.t0 = ctx.clock
        self._last = ctx.q[:2].copy()

    def step(self, ctx: Context) -> str | None:
        q = ctx.q
        m = ctx.metrics
        m["base_travel_m"] = round(
            float(m.get("base_travel_m", 0.0)) + float(np.hypot(*(q[:2] - self._last))), 4
        )
        self._last = q[:2].copy()
        if self.motion is None:
            return self.blocked
        elapsed = ctx.clock - self.t0
        if not self.motion.command(ctx, elapsed):
            return None
        dist, dyaw = self.motion.error(ctx)
        p = self.params
        if dist <= p.tolerance_m and dyaw <= math.radians(p.tolerance_deg):
            return self.arrived
        if elapsed > self.motion.duration + p.settle_s:
            ctx.log(
                "skill",
                f"{self.name}: base {dist * 1000:.1f} mm, {math.degrees(dyaw):.2f}"
                " deg from its goal after settling",
                level="WARN",
            )
            return "timeout"
        return None

    def explain(self, ctx: Context) -> str | None:
        if getattr(self, "motion", None) is None:
            return f"{self.name}: no collision-free way for the base"
        dist, dyaw = self.motion.error(ctx)
        return f"{self.name}: base {dist * 1000:.1f} mm, {math.degrees(dyaw):.2f} deg from its goal"
