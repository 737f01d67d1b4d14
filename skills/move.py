"""`move`: the TCP along a straight Cartesian line to a pose, tracked with mink IK."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any, ClassVar, Literal

import numpy as np
from pydantic import Field, PositiveFloat

from orchestrator.world.pose import Pose

from .base import SCENE_TARGET, Skill, SkillParams
from .targets import resolve_target, rot_down, yaw_of_rot
from .trajectory import CartesianLine

if TYPE_CHECKING:
    from orchestrator.engine.context import Context

__all__ = ["Move"]

_AT_REST_MPS = 0.005
"""TCP speed below which the arm counts as at rest [m/s]."""
_CAUGHT_UP_RAD = 0.01
"""The limited joint command is this close to the IK's solution: hold the solution [rad]."""


class MoveParams(SkillParams):
    target: Any = Field(
        description="`[x, y, z]` in the world [m], an object or marker name, or a pose "
        "(`$object_pose`).",
        json_schema_extra=SCENE_TARGET,
    )
    offset: list[float] = Field(
        default_factory=lambda: [0.0, 0.0, 0.0],
        min_length=3,
        max_length=3,
        description="Added to the target position, world frame [m].",
    )
    orientation: Literal["down", "keep"] | list[float] = Field(
        default="down",
        description="`down` (TCP z to -z), `keep` (the start orientation) or a quaternion w,x,y,z.",
    )
    align_yaw: bool = Field(
        default=False, description="Turn about world z to the target's yaw (modulo the symmetry)."
    )
    yaw_symmetry_deg: PositiveFloat = Field(
        default=90.0, le=360.0, description="Symmetry of the target about z [deg]."
    )
    max_speed: PositiveFloat = Field(default=0.5, le=2.0, description="[m/s]")
    max_accel: PositiveFloat = Field(default=2.0, le=20.0, description="[m/s^2]")
    max_angular_speed: PositiveFloat = Field(default=2.0, le=6.0, description="[rad/s]")
    max_angular_accel: PositiveFloat = Field(default=8.0, le=50.0, description="[rad/s^2]")
    tolerance_m: PositiveFloat = Field(default=0.001, description="Position tolerance [m].")
    tolerance_deg: PositiveFloat = Field(default=0.5, description="Orientation tolerance [deg].")
    settle_s: PositiveFloat = Field(
        default=1.0, description="Time allowed after the line ends to settle within tolerance [s]."
    )


class Move(Skill):
    """Drive the TCP to a pose along a straight line with trapezoidal timing.

    Outcomes: `reached` (TCP within tolerance and at rest), `unreachable` (outside the arm's
    reach, or the IK cannot get there), `timeout` (the arm did not settle in `settle_s`).
    """

    name: ClassVar[str] = "move"
    Params: ClassVar[type[SkillParams]] = MoveParams
    outcomes: ClassVar[tuple[str, ...]] = ("reached", "unreachable", "timeout")

    params: MoveParams

    def start(self, ctx: Context) -> None:
        p = self.params
        goal = resolve_target(ctx, p.target)
        pos1 = np.asarray(goal.pos) + np.asarray(p.offset)
        rot0 = ctx.tcp_rot.copy()
        if p.orientation == "keep":
            rot1 = rot0
        elif p.orientation == "down":
            yaw = yaw_of_rot(rot0)
            if p.align_yaw:
                yaw = _nearest_symmetric(goal.yaw, yaw, math.radians(p.yaw_symmetry_deg))
            rot1 = rot_down(yaw)
        else:
            rot1 = _quat_to_rot(np.asarray(p.orientation, float))
        self.pos1, self.rot1 = pos1, rot1
        self.reachable = _within_reach(ctx, pos1)
        ctx.ik.reset(ctx.q)
        self.line = CartesianLine(
            ctx.tcp_pos.copy(),
            rot0,
            pos1,
            rot1,
            p.max_speed,
            p.max_accel,
            p.max_angular_speed,
            p.max_angular_accel,
        )
        self.t0 = ctx.clock
        self.ik_stalled_ticks = 0
        self.last_tcp = ctx.tcp_pos.copy()
        ctx.ik_target = Pose(pos=pos1.tolist(), quat=_rot_to_quat(rot1).tolist())

    def step(self, ctx: Context) -> str | None:
        if not self.reachable:
            ctx.log("skill", f"move: target {np.round(self.pos1, 3).tolist()} is out of reach")
            return "unreachable"
        p = self.params
        elapsed = ctx.clock - self.t0
        pos, rot = self.line.sample_so3(elapsed)
        q = ctx.ik.step(pos, rot)
        ctx.controller.set_joint_target(q, ctx.ik.velocity, ctx.ik.acceleration)
        tcp = ctx.tcp_pos
        if elapsed < self.line.duration:
            self.last_tcp[:] = tcp
            return None
        tcp_speed = float(np.linalg.norm(tcp - self.last_tcp)) / ctx.dt_control
        self.last_tcp[:] = tcp
        pos_err, ang_err = self.tcp_error(ctx)
        if pos_err <= p.tolerance_m and ang_err <= math.radians(p.tolerance_deg):
            if tcp_speed < _AT_REST_MPS:
                return "reached"
        ik_err = ctx.ik.error
        ik_converged = np.linalg.norm(ik_err[:3]) <= 0.5 * p.tolerance_m and np.linalg.norm(
            ik_err[3:]
        ) <= 0.5 * math.radians(p.tolerance_deg)
        if not ik_converged and float(np.max(np.abs(ctx.ik.velocity))) < 1e-3:
            self.ik_stalled_ticks += 1
            if self.ik_stalled_ticks >= 10:  # the IK is stuck short of the target: limits
                ctx.log("skill", "move: IK stalled short of the target (joint limits)")
                return "unreachable"
        else:
            self.ik_stalled_ticks = 0
        if elapsed > self.line.duration + p.settle_s:
            return "unreachable" if not ik_converged else "timeout"
        return None

    def stop(self, ctx: Context) -> None:
        # Hold the IK's solution (where the arm is meant to be) once the limited command has
        # caught up with it; if the move was cut short, hold where the command is, not jump.
        ik = ctx.ik
        if not self.reachable:
            ctx.controller.hold(ctx.q)
        elif float(np.max(np.abs(ik.q - ik.command))) <= _CAUGHT_UP_RAD:
            ctx.controller.hold(ik.q)
        else:
            ctx.controller.hold(ik.command)
        ctx.ik_target = None

    def tcp_error(self, ctx: Context) -> tuple[float, float]:
        """Measured TCP position error [m] and orientation error [rad] to the goal."""
        pos_err = float(np.linalg.norm(ctx.tcp_pos - self.pos1))
        r_err = ctx.tcp_rot.T @ self.rot1
        ang_err = math.acos(max(-1.0, min(1.0, (np.trace(r_err) - 1.0) / 2.0)))
        return pos_err, ang_err


def _within_reach(ctx: Context, pos: np.ndarray) -> bool:
    base = np.asarray(ctx.scenario.robot.base_pos)
    shoulder = base + np.array([0.0, 0.0, ctx.robot.shoulder_height_m])
    return bool(np.linalg.norm(pos - shoulder) <= ctx.robot.reach_m and np.all(np.isfinite(pos)))


def _nearest_symmetric(target_yaw: float, current_yaw: float, period: float) -> float:
    k = round((current_yaw - target_yaw) / period)
    return target_yaw + k * period


def _quat_to_rot(quat: np.ndarray) -> np.ndarray:
    import mujoco

    out = np.zeros(9)
    mujoco.mju_quat2Mat(out, quat / np.linalg.norm(quat))
    return out.reshape(3, 3)


def _rot_to_quat(rot: np.ndarray) -> np.ndarray:
    import mujoco

    out = np.zeros(4)
    mujoco.mju_mat2Quat(out, rot.reshape(9))
    return out
