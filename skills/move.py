"""`move`: the TCP along a straight Cartesian line to a pose, tracked with mink IK."""

from __future__ import annotations

import math
from dataclasses import asdict
from typing import TYPE_CHECKING, Any, ClassVar, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, PositiveFloat, model_validator

from orchestrator.world.pose import Pose

from .base import SCENE_TARGET, Skill, SkillParams
from .blended_path import BlendedPath
from .dry_run import DryRun, dry_run
from .move_state import PATHS, dry_from, path_from, path_state
from .plain_state import plain_state, restore_plain
from .targets import resolve_target, rot_down, yaw_of_rot
from .time_scaling import feasible_time_scale, fit_path_to_joints, slow_where_exceeded
from .trajectory import CartesianLine

if TYPE_CHECKING:
    import mink

    from orchestrator.engine.context import Context

__all__ = ["Move", "symmetric_yaws"]

_AT_REST_MPS = 0.005
"""TCP speed below which the arm counts as at rest [m/s]."""
_SETTLE_GAIN = 8.0
"""Integral gain of the settling correction [1/s]: the IK target moves by this fraction of the
measured TCP error per second once the line has ended (see `Move.step`)."""
_MAX_CORRECTION_M = 0.015
"""Largest settling correction of the position [m] (4.8 mm are needed at a 0.5 kg payload)."""
_MAX_CORRECTION_RAD = math.radians(3.0)
"""Largest settling correction of the orientation [rad] (0.63 deg at a 0.5 kg payload)."""
MAX_LAG_RAD = 0.03
"""Largest lag of the limited joint command behind the IK's reference a move accepts [rad];
beyond it the move is slowed as a whole (`_RETIME`). The nominal flows lag at most 0.018 rad;
a grasp at the edge of the reach lagged 0.145 rad at its blended corner, the hand left its
path by 2 cm and a finger came down on the parcel (96 N)."""
MAX_TORQUE_FRACTION = 0.8
"""Largest fraction of a joint's torque limit a move's reference may ask for (gravity and its
own accelerations, the robot's model, no payload); beyond it the move is slowed, and a pose
that needs it even at rest is unreachable. The `joint_torque` guard aborts at 90 % for 20 ms:
a lift of a 0.4 kg parcel 0.78 m out did (joint 2 at 61 % holding it still, 90 % lifting it
at 6 m/s^2). pick_place's moves ask at most 59 %."""
MIN_SIGMA = 0.05
"""Smallest singular value of the TCP's Jacobian a move's target may have: nearer a
singularity (the arm stretched out), the IK's reference reaches the pose, but the settling
correction that takes out the arm's sag turns into large joint motions (a grasp with 0.04
there swung joint 2 by 0.17 rad and hit its torque limit). Poses the flows use: 0.06-0.2."""
_ON_GRID_S = 1e-6
"""A tick whose clock is within this of a whole number of control periods since the start is
on the dry run's grid (`dry_run.path_time`) [s]: the simulated clock, a sum of physics steps,
drifts from it by ~1e-14 s; a pause's ramp slows it by 4e-4 s in its first tick."""
_RETIME = 1.3
"""Factor by which a move whose command would lag is slowed, per try."""
_MAX_RETIMES = 6
"""Tries at slowing a lagging move (1.3^6 = 4.8x its duration at most)."""


class Via(BaseModel):
    """A point the motion passes through without stopping."""

    model_config = ConfigDict(defer_build=True, extra="forbid")

    target: Any = Field(
        description="`[x, y, z]` in the world [m], an object or marker name, or a pose.",
        json_schema_extra=SCENE_TARGET,
    )
    offset: list[float] = Field(
        default_factory=lambda: [0.0, 0.0, 0.0],
        min_length=3,
        max_length=3,
        description="Added to the via point's position, world frame [m].",
    )


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
    stop_at_target: bool = Field(
        default=True,
        description="Come to rest at the target before `reached`; false: `reached` as soon as "
        "the TCP is within tolerance at the end of the motion (for a motion the next state "
        "continues, e.g. a lift or a retreat).",
    )
    via: list[Via] = Field(
        default_factory=list,
        max_length=16,
        description="Points passed through on the way without stopping, in order (e.g. a "
        "hover point above the target); the corners are rounded by `blend_m` and the "
        "orientation is reached at the last one.",
    )
    blend_m: float = Field(
        default=0.03,
        ge=0.0,
        le=0.5,
        description="How far before and after a via point the path starts and ends rounding "
        "its corner [m] (0: a sharp corner, passed at rest).",
    )
    guarded_from_m: float = Field(
        default=0.0,
        ge=0.0,
        le=0.5,
        description="A guarded last stretch: where it starts, this far above the target "
        "(world z) [m] (0: none). Between `guarded_from_m` and `guarded_to_m` above the target, "
        "on the path's last descent, the motion goes at `guarded_speed_mps`: a finger that meets "
        "the object there lands slowly, and a `watch_force` with the same band feels it.",
    )
    guarded_to_m: float = Field(
        default=0.0,
        ge=0.0,
        le=0.5,
        description="Where the guarded stretch ends, above the target [m]; the rest of the "
        "way at `max_speed`.",
    )
    guarded_lead_m: float = Field(
        default=0.006,
        ge=0.0,
        le=0.1,
        description="The slow speed holds this far beyond the guarded stretch at each end "
        "[m]: braked into it, the arm lags its reference (a UR5 still at 0.1 m/s at the "
        "stretch's top, its hand's deceleration 2.6-2.8 N at the wrist), and speeding up again "
        "below it reads ~3 N; with the lead a watch over the stretch feels only a touch.",
    )
    guarded_lead_below_m: float | None = Field(
        default=None,
        ge=0.0,
        le=0.1,
        description="The slow speed's lead below the guarded stretch [m] (None: "
        "`guarded_lead_m`): speeding up again starts once the arm, trailing its reference by "
        "~1 mm at the slow speed, is past the stretch, so a watch over it does not feel it.",
    )
    guarded_speed_mps: PositiveFloat = Field(
        default=0.05,
        le=0.5,
        description="Top speed over the guarded stretch [m/s]: a Panda fingertip landing on a "
        "cube at 0.05 m/s peaks joint 2 at 0.8-0.9 of its datasheet acceleration (0.07: up to "
        "1.06, 0.1: 1.2).",
    )
    time_optimal: bool = Field(
        default=False,
        description="Time the motion as a path (a straight one without `via`) slowed only "
        "where a joint needs it, from the IK's dry run along it, instead of slowing the whole "
        "motion by its worst point; nothing the joints may not do either way.",
    )
    gripper_m: float | None = Field(
        default=None,
        ge=0.0,
        le=0.1,
        description="Set each finger to this opening at the start of the motion (as "
        "`release`'s `opening_m`), so the fingers pre-shape while the arm moves [m].",
    )

    @model_validator(mode="after")
    def _guarded_stretch(self) -> MoveParams:
        # a stretch given upside down (or empty) would silently leave the approach unguarded;
        # guarded_from_m 0 is "none" whatever guarded_to_m says
        top, bottom = self.guarded_from_m, self.guarded_to_m
        if top > 0.0 and top <= bottom:
            raise ValueError(
                f"guarded_from_m {top:g} must be above guarded_to_m {bottom:g}: the guarded "
                f"stretch runs down from guarded_from_m to guarded_to_m above the target (e.g. "
                f"guarded_from_m: 0.04, guarded_to_m: 0.03; guarded_from_m 0: none)"
            )
        return self


class Move(Skill):
    """Drive the TCP to a pose along a straight line with jerk-limited timing, or through
    `via` points with blended corners and a time-optimal timing law.

    Before anything moves, the IK runs along the whole motion (its dry run, kept as `dry`:
    the joint path the ticks then command), for each orientation the target allows (with
    `align_yaw`, its symmetric yaws, the least wrist turn first): the first that gets there
    is the motion. A motion whose joint command would lag the IK by more than 0.03 rad, or ask
    a joint for more than 80 % of its torque, is slowed as a whole until it does not.

    Outcomes: `reached` (TCP within tolerance and at rest), `unreachable` (at once, before
    moving: beyond the arm's reach, the IK stuck short of the pose in every orientation — the
    residual is in the transition's detail —, too close to a singularity, or too much torque
    even slowly; or, later, the IK stalled), `timeout` (the arm did not settle in `settle_s`).

    Metrics (of the last `move` that ended, however it ended): `tcp_error_mm`, the true TCP's
    distance to the target position [mm], and `tcp_target_m`, that position [m].
    """

    name: ClassVar[str] = "move"
    Params: ClassVar[type[SkillParams]] = MoveParams
    outcomes: ClassVar[tuple[str, ...]] = ("reached", "unreachable", "timeout")

    params: MoveParams

    def snapshot_state(self) -> dict[str, Any]:
        """Plain data, and the motion it follows: its line (or blended path) and its dry
        runs, each as its data (`restore_state` makes them again from it)."""
        state: dict[str, Any] = plain_state(self)
        line = getattr(self, "line", None)
        if line is not None:
            state["$line"] = {"kind": type(line).__name__, "data": path_state(line)}
        state["$dry"] = None if getattr(self, "dry", None) is None else asdict(self.dry)
        state["$tried"] = [asdict(d) for d in getattr(self, "tried", [])]
        return state

    def restore_state(self, data: dict[str, Any]) -> None:
        """Take back what `snapshot_state` recorded (a resumed run's move: `start` is not run
        again; the motion it had planned is made again from its data)."""
        data = dict(data)
        line, dry, tried = data.pop("$line", None), data.pop("$dry", None), data.pop("$tried", [])
        restore_plain(self, data)
        if line is not None:
            cls = PATHS.get(line["kind"])
            if cls is None:
                raise ValueError(f"move: no kind of path {str(line['kind'])[:40]!r}")
            self.line = path_from(cls, line["data"])
        self.dry = None if dry is None else dry_from(dry)
        self.tried = [dry_from(d) for d in tried]

    def start(self, ctx: Context) -> None:
        p = self.params
        goal = resolve_target(ctx, p.target)
        pos1 = np.asarray(goal.pos) + np.asarray(p.offset)
        rot0 = ctx.tcp_rot.copy()
        if p.orientation == "keep":
            rots = [_keepable(ctx, rot0)]
        elif p.orientation == "down":
            yaw = yaw_of_rot(rot0)
            yaws = (
                symmetric_yaws(goal.yaw, yaw, math.radians(p.yaw_symmetry_deg))
                if p.align_yaw
                else [yaw]
            )
            rots = [rot_down(y) for y in yaws]
        else:
            rots = [_quat_to_rot(np.asarray(p.orientation, float))]
        self.pos1, self.rot1 = pos1, rots[0]
        vias = [np.asarray(resolve_target(ctx, v.target).pos) + np.asarray(v.offset) for v in p.via]
        self.reachable = all(_within_reach(ctx, x) for x in (*vias, pos1))
        ctx.ik.reset(ctx.q)
        if p.gripper_m is not None:
            ctx.set_gripper(p.gripper_m)
        self.t0 = ctx.clock
        self.stretch = 1.0
        self.dry: DryRun | None = None
        """The IK's reference along the chosen motion (skills/dry_run.py), None when the
        target is beyond the arm's reach (no dry run then)."""
        self.tried: list[DryRun] = []
        """The dry runs of the orientations tried, in order (the last is `dry`)."""
        self.line = self._line(ctx, vias, rot0, rots[0])
        for rot1 in rots if self.reachable else ():
            # each orientation the target allows (its symmetric yaws, nearest first): the
            # first whose dry run reaches it is the motion; none: unreachable, at once
            line = self._line(ctx, vias, rot0, rot1)
            if isinstance(line, BlendedPath):
                fit_path_to_joints(ctx.ik, line, ctx.q)
            if isinstance(line, BlendedPath) and p.time_optimal:
                stretch = slow_where_exceeded(ctx.ik, line, ctx.q)
            else:
                stretch = feasible_time_scale(ctx.ik, line, ctx.q)
            command = (ctx.controller.q_d, ctx.controller.qd_d)
            tol_rad = math.radians(p.tolerance_deg)
            limit = ctx.world.arm_effort_limit
            args = (p.settle_s, p.tolerance_m, tol_rad, command, limit)
            run = dry_run(ctx.ik, line, stretch, ctx.q, *args)
            for _ in range(_MAX_RETIMES):
                if not run.reached or (
                    run.lag_rad <= MAX_LAG_RAD and run.torque_ratio[0] <= MAX_TORQUE_FRACTION
                ):
                    break
                # the limited command would fall behind and leave the path (near the edge of
                # the reach, a blend's turn), or a joint would need most of its torque (a lift
                # at full stretch): slower, until it keeps up
                stretch *= _RETIME
                run = dry_run(ctx.ik, line, stretch, ctx.q, *args)
            self.tried.append(run)
            if run.reached and run.torque_ratio[0] > MAX_TORQUE_FRACTION:
                continue  # even slowly: holding the pose takes nearly all of a joint's torque
            if run.reached and run.sigma_min < MIN_SIGMA:
                continue  # the arm stretched out: no correction could settle it there
            if run.reached:
                self.line, self.rot1, self.stretch, self.dry = line, rot1, stretch, run
                break
        else:
            self.reachable = False
        # the command starts from the controller's setpoint, not the measured (sagging) joints
        ctx.ik.restart_from(ctx.controller.q_d, ctx.controller.qd_d)
        self.duration = self.line.duration * self.stretch
        self.corr_pos = np.zeros(3)
        self.corr_rot = np.zeros(3)
        self.ik_stalled_ticks = 0
        self.following = self.dry is not None
        """The ticks so far followed the dry run's reference (`_follow`); from the first
        that solved the IK live on, none does."""
        self.replayed = 0
        """Rows of the dry run's reference followed so far."""
        self.last_tcp = ctx.tcp_pos.copy()
        ctx.ik_target = Pose(pos=pos1.tolist(), quat=_rot_to_quat(self.rot1).tolist())

    def _line(
        self, ctx: Context, vias: list[np.ndarray], rot0: np.ndarray, rot1: np.ndarray
    ) -> CartesianLine | BlendedPath:
        """The motion from the TCP to `pos1` with orientation `rot1` (through `vias`)."""
        p = self.params
        guarded = p.guarded_from_m > p.guarded_to_m
        if vias or guarded or p.time_optimal:
            path = BlendedPath(
                np.array([ctx.tcp_pos, *vias, self.pos1]),
                rot0,
                rot1,
                p.max_speed,
                p.max_accel,
                p.max_angular_speed,
                p.max_angular_accel,
                p.blend_m,
            )
            if guarded:
                z = float(self.pos1[2])
                lead = p.guarded_lead_m
                below = lead if p.guarded_lead_below_m is None else p.guarded_lead_below_m
                low, high = z + p.guarded_to_m - below, z + p.guarded_from_m + lead
                path.slow_between(low, high, p.guarded_speed_mps)
            return path
        return CartesianLine(
            ctx.tcp_pos.copy(),
            rot0,
            self.pos1,
            rot1,
            p.max_speed,
            p.max_accel,
            p.max_angular_speed,
            p.max_angular_accel,
        )

    def step(self, ctx: Context) -> str | None:
        if not self.reachable:
            ctx.log("skill", f"move: {self.explain(ctx)}")
            return "unreachable"
        p = self.params
        elapsed = ctx.clock - self.t0
        q = self._follow(ctx, elapsed) if self.following else None
        if q is None:  # after the path (corrected), or the clock slowed by a pause
            self.following = False
            pos, rot = self.line.sample_so3(elapsed / self.stretch)
            if elapsed >= self.duration:
                pos, rot = self._corrected(ctx, pos, rot)
            q = ctx.ik.step(pos, rot)
        ctx.controller.set_joint_target(q, ctx.ik.velocity, ctx.ik.acceleration)
        tcp = ctx.tcp_pos
        if elapsed < self.duration:
            self.last_tcp[:] = tcp
            return None
        tcp_speed = float(np.linalg.norm(tcp - self.last_tcp)) / ctx.dt_control
        self.last_tcp[:] = tcp
        pos_err, ang_err = self.tcp_error(ctx)
        if pos_err <= p.tolerance_m and ang_err <= math.radians(p.tolerance_deg):
            if tcp_speed < _AT_REST_MPS or not p.stop_at_target:
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
        if elapsed > self.duration + p.settle_s:
            return "unreachable" if not ik_converged else "timeout"
        return None

    def _follow(self, ctx: Context, elapsed: float) -> np.ndarray | None:
        """This tick's command from the dry run's reference (`IKSolver.follow`), or None
        where the IK must solve live.

        On the path, at a whole number `k` of control periods since the start, the dry run
        solved the IK already, from the same state for the same target (`dry_run.path_time`):
        its row `k - 1` is what a solve would give, bit for bit. `k` = 0 (the state's first
        tick in the one it started in) is the path's start, where the reference already is.
        Not on the grid (a pause's ramp slowed the clock), or once the path has ended (the
        target then moves by the measured error), the IK solves live from then on.
        """
        dry = self.dry
        if dry is None or elapsed >= self.duration:
            return None
        k = round(elapsed / dry.dt)
        if abs(elapsed - k * dry.dt) > _ON_GRID_S:
            return None
        if k == 0 and self.replayed == 0:
            return ctx.ik.hold()
        if k - 1 != self.replayed or k > dry.path_ticks:
            return None
        self.replayed = k
        return ctx.ik.follow(dry.q_path[k - 1], dry.velocity[k - 1])

    def _corrected(self, ctx: Context, pos: np.ndarray, rot: mink.SO3) -> tuple:
        """The end of the line moved by the integral of the measured TCP error.

        The controller's model does not know a carried payload, so under joint impedance the
        arm sags below where the IK put it (4.8 mm and 0.6 deg at 0.5 kg). Integrating the
        measured error into the IK target removes that steady-state error, as a robot's own
        position loop would; it is bounded, and only runs once the line has ended.
        """
        import mink

        dt = ctx.dt_control
        self.corr_pos += _SETTLE_GAIN * dt * (self.pos1 - ctx.tcp_pos)
        norm = float(np.linalg.norm(self.corr_pos))
        if norm > _MAX_CORRECTION_M:
            self.corr_pos *= _MAX_CORRECTION_M / norm
        tcp_rot = ctx.tcp_rot
        err_world = tcp_rot @ mink.SO3.from_matrix(tcp_rot.T @ self.rot1).log()
        self.corr_rot += _SETTLE_GAIN * dt * err_world
        norm = float(np.linalg.norm(self.corr_rot))
        if norm > _MAX_CORRECTION_RAD:
            self.corr_rot *= _MAX_CORRECTION_RAD / norm
        return pos + self.corr_pos, mink.SO3.exp(self.corr_rot) @ rot

    def stop(self, ctx: Context) -> None:
        # The reach result: where the TCP truly is (MuJoCo's site, not the controller's model)
        # against the target, when the motion ends (reached, unreachable, timeout or aborted).
        ctx.metrics["tcp_error_mm"] = round(float(np.linalg.norm(ctx.tcp_pos - self.pos1)) * 1e3, 4)
        ctx.metrics["tcp_target_m"] = [round(float(v), 6) for v in self.pos1]
        # Hold where the command is, bringing it to rest if it still moves (a move that does
        # not stop at its target, the arm's posture still settling): never a jump of the
        # setpoint or of its velocity, which the arm would follow with a kick.
        # Refused at once (unreachable), the move never commanded anything: the setpoint the
        # previous state left is kept too. Held at the measured angles instead, the joint
        # impedance let go of the load it carried (a payload the controller's model lacks):
        # with a 2.5 kg cube joint 2's torque fell by 10 Nm in one step, the arm sagged and
        # the end-of-run stop's brakes caught it at speed (joint 6 at 113 rad/s^2).
        ctx.controller.hold_setpoint()
        ctx.ik_target = None

    def explain(self, ctx: Context) -> str | None:
        """The TCP's remaining error against the tolerance, or why the target is unreachable."""
        p = self.params
        if not self.reachable:
            return self._unreachable()
        pos_err, ang_err = self.tcp_error(ctx)
        ik_pos = float(np.linalg.norm(ctx.ik.error[:3]))
        text = (
            f"TCP {pos_err * 1000:.1f} mm from the target (tolerance_m "
            f"{p.tolerance_m * 1000:g} mm), {math.degrees(ang_err):.2f} deg off (tolerance_deg "
            f"{p.tolerance_deg:g})"
        )
        elapsed = ctx.clock - self.t0
        if elapsed < self.duration:
            return text + f"; still on its line ({elapsed:.2f} of {self.duration:.2f} s)"
        if ik_pos > 0.5 * p.tolerance_m:
            text += f"; the IK is stuck {ik_pos * 1000:.1f} mm short (joint limits)"
        return text

    def _unreachable(self) -> str:
        """Why the target is unreachable, with the dry run's residual."""
        target = np.round(self.pos1, 3).tolist()
        if not self.tried:
            return f"target {target} is beyond the arm's reach"
        stretched = [r for r in self.tried if r.reached and r.sigma_min < MIN_SIGMA]
        if stretched:
            sigma = max(r.sigma_min for r in stretched)
            return (
                f"target {target} unreachable: the arm would be stretched out there, close to "
                f"a singularity (the TCP Jacobian's smallest singular value {sigma:.3f}, at "
                f"least {MIN_SIGMA:g})"
            )
        strained = [r for r in self.tried if r.reached]
        if strained:
            ratio, joint = min(r.torque_ratio for r in strained)
            return (
                f"target {target} unreachable: joint {joint + 1} would need "
                f"{ratio * 100:.0f} % of its torque limit to take the arm there, even slowly "
                f"(at most {MAX_TORQUE_FRACTION * 100:.0f} %: too far out)"
            )
        best = min(self.tried, key=lambda r: (r.residual_m, r.residual_rad))
        ways = f"in any of {len(self.tried)} orientations" if len(self.tried) > 1 else "there"
        return (
            f"target {target} unreachable: the IK gets {best.residual_m * 1000:.1f} mm and "
            f"{math.degrees(best.residual_rad):.1f} deg from it at best {ways} (joint limits "
            "or the edge of the reach)"
        )

    def tcp_error(self, ctx: Context) -> tuple[float, float]:
        """Measured TCP position error [m] and orientation error [rad] to the goal."""
        pos_err = float(np.linalg.norm(ctx.tcp_pos - self.pos1))
        r_err = ctx.tcp_rot.T @ self.rot1
        ang_err = math.acos(max(-1.0, min(1.0, (np.trace(r_err) - 1.0) / 2.0)))
        return pos_err, ang_err


FEW_AXES_DOWN_DEG = 2.0
"""A hand of an arm with fewer than six joints pointing within this of straight down keeps its
heading, pointing down (`_keepable`) [deg]."""


def _keepable(ctx: Context, rot0: np.ndarray) -> np.ndarray:
    """The start orientation `rot0` as the arm can keep it elsewhere. At a point, an arm with
    fewer than six joints (the 5-axis SO-101) reaches only a 2-parameter family of
    orientations: pointing straight down at any heading is among them throughout its
    workspace, the few tenths of a degree of tilt a grasp's squeeze leaves the hand with are
    not (pick_place's TRANSPORT failed `unreachable` by 0.6-1.2 deg). Such a hand, pointing
    within `FEW_AXES_DOWN_DEG` of down, keeps its heading, pointing down; a six-joint arm keeps
    `rot0` itself."""
    robot = ctx.robot
    if robot.n_arm - len(robot.base_joints) >= 6:
        return rot0
    if math.degrees(math.acos(max(-1.0, min(1.0, -float(rot0[2, 2]))))) > FEW_AXES_DOWN_DEG:
        return rot0
    return rot_down(yaw_of_rot(rot0))


def _within_reach(ctx: Context, pos: np.ndarray) -> bool:
    shoulder = ctx.robot.shoulder(ctx.q, np.asarray(ctx.scenario.robot.base_pos))
    return bool(np.linalg.norm(pos - shoulder) <= ctx.robot.reach_m and np.all(np.isfinite(pos)))


def symmetric_yaws(target_yaw: float, current_yaw: float, period: float) -> list[float]:
    """The yaws [rad] a target of symmetry `period` [rad] can be taken at, within half a turn
    of `current_yaw` [rad] (unwrapped, as the wrist stands), nearest first: the nearest is the
    least wrist turn; the others when it cannot be reached."""
    k0 = round((current_yaw - target_yaw) / period)
    n = max(1, round(2.0 * math.pi / period))
    ks = sorted(range(k0 - n, k0 + n + 1), key=lambda k: (abs(k - k0), k))
    out: list[float] = []
    for k in ks:
        yaw = target_yaw + k * period
        if abs(yaw - current_yaw) <= math.pi + 1e-9 and len(out) < n:
            out.append(yaw)
    return out or [target_yaw + k0 * period]


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
