"""The controlled stop: brake the arm to standstill under control, hold it, and measure it.

Every abort (a guard, an e-stop), and every end of a run, goes through it. It is judged by the
arm, not the log: the stop is over when the braking profile has ended and every arm joint
moves slower than `rest_speed_rad_s`, measured every physics step on MuJoCo's state.

The stop is monitored like a safe stop 1 (SS1) of a safety controller: a joint that does not
follow its braking profile (its motor is lost or too weak) gets its holding brake at once, and
once the profile has brought the commanded speed to zero the drives hand the arm to the
holding brakes of every joint (a category-1 stop: power is removed at standstill). The brakes
hold the stopped pose whatever the motors do — a lost or saturated one included. A normal end
of a run (`gentle`) keeps the motors holding instead (a category-2 stop).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import mujoco
import numpy as np

from ..robots.controller import ControlMode

if TYPE_CHECKING:
    from ..language.scenario import SafeStop
    from .context import Context

__all__ = ["BRAKE_TRACKING_RAD", "REST_STEPS", "SafetyStop", "profile_distance_m"]

BRAKE_TRACKING_RAD = 0.05
"""A held joint this far from where it is held gets its holding brake [rad]."""
HELD_STOP_RAD = 0.01
"""A normal stop of an arm held (HOLD) within this of its setpoint on every joint, and slower
than `HELD_STOP_RAD_S`, keeps it held there rather than braking from the measured state [rad]
(a skill that ended mid-motion leaves HOLD at the measured angles with the arm still moving:
that one is braked)."""
HELD_STOP_RAD_S = 0.05
"""See `HELD_STOP_RAD` [rad/s] (the SO-101's wrist, held against its jaw: 0.018)."""
REST_STEPS = 5
"""Physics steps in a row every arm joint must stay below the rest speed for the stop to be
over (10 ms): a push still acting when the stop began slipped a wrist brake for one step at
0.11 rad/s just after the arm had first read as still."""
WEAK_MOTOR_NM = 0.5
"""A motor delivering this much less than commanded when the stop starts is braked [Nm]."""
BRAKE_OVERSPEED_RAD_S = 0.1
"""A joint this much faster than its braking profile allows gets its holding brake [rad/s].
At 0.3 a wrist joint ran 0.26 rad/s ahead of its profile (the velocity servo lags: the
controller's model lacks the rotors' inertia) and a 0.25 m/s stop travelled 1.5x the
profile's own distance; at 0.05 the brakes took over from the profile on most joints of a
1 m/s stop and stopped the TCP 26 % short of it, off its path."""


def profile_distance_m(tcp_speed_m_s: float, qd: np.ndarray, decel: float) -> float:
    """TCP travel [m] of the synchronized braking profile from a trip at TCP speed
    `tcp_speed_m_s` [m/s] with joint velocities `qd` [rad/s] (shape (n,)), the slowest joint
    decelerating at `decel` [rad/s^2]: every joint velocity falls linearly to zero over
    T = max |qd| / decel, so the TCP's speed does too (to first order) and it travels
    v T / 2. The least a stop that keeps the arm on its path can travel within the limit."""
    duration = float(np.max(np.abs(qd))) / decel if len(qd) else 0.0
    return 0.5 * tcp_speed_m_s * duration


class SafetyStop:
    """One controlled stop of the arm, stepped by the runner every physics step.

    Args:
        ctx: The episode context.
        config: The scenario's `physics.safe_stop`.
    """

    def __init__(self, ctx: Context, config: SafeStop) -> None:
        self.ctx = ctx
        self.config = config
        self._tcp = ctx.data.site_xpos[ctx.world.tcp_site]  # a view: MjData never reallocates
        self.active = False
        self.reason = ""
        self.start_t = math.nan
        self.stop_time_s: float | None = None
        """Start -> every arm joint below the rest speed, braking over [s]; None while stopping."""
        self.distance_m = 0.0
        """TCP path length since the start [m] (until the arm is at rest)."""
        self.distance_min_m = 0.0
        """The braking profile's own TCP travel from the speed at the start [m]
        (`profile_distance_m`): what `distance_m` is measured against."""
        self.tcp_speed_m_s = 0.0
        """TCP speed when the stop started [m/s]."""
        self.braked_joints: list[int] = []
        """Joints braked because they could not follow the profile (their motor failed)."""
        self.gentle = False
        self.lock_at_rest = False
        self.locked = False
        """The holding brakes of every joint hold the stopped arm (category 1)."""
        self._still_steps = 0
        self._last_tcp = (0.0, 0.0, 0.0)

    @property
    def at_rest(self) -> bool:
        """The stop has ended: the arm is still and held."""
        return self.stop_time_s is not None

    def start(self, reason: str, gentle: bool = False, brake: bool = True) -> None:
        """Brake from the measured state (read on the safety encoders).

        Args:
            reason: Why (for the log).
            gentle: At the robot's own acceleration limits (the end of a run, a normal stop)
                rather than at the safety stop's `max_decel_rad_s2` (an abort); the motors,
                not the brakes, then hold the stopped arm.
            brake: After an abort, the holding brakes take the arm once the braking profile
                has ended. False when an `on_abort` response takes the arm over at once:
                locked for the few steps before it does, a probe pressed into tissue read
                8 N (the brakes' rigid friction against the soft contact) instead of its 2 N.
        """
        ctx = self.ctx
        if not gentle:
            ctx.cell.encoders.failover()
        q, qd = ctx.cell.encoders.safety_channel()
        n = ctx.robot.n_arm
        ctrl = ctx.controller
        held = (
            ctrl.mode is ControlMode.HOLD
            and bool(np.all(np.abs(ctrl.q_d - q[:n]) < HELD_STOP_RAD))
            and float(np.max(np.abs(qd[:n]))) < HELD_STOP_RAD_S
        )
        if gentle and (held or float(np.max(np.abs(qd[:n]))) < self.config.rest_speed_rad_s):
            # still, or held where it is by the joint impedance: it stays held, with what the
            # spring carried. Braked from the measured state instead (a velocity servo with
            # no spring), a wrist held against the SO-101's jaw pushing a cube that stuck
            # lost the spring's torque in one step: joint 3 at 1.13x its datasheet
            # acceleration in a time-limit stop during CLOSE
            ctrl.hold_setpoint()
        else:
            # a normal stop within the limits the commands keep to (the arm overshoots a
            # profile at the datasheet limit by ~20 %); an abort at the safety stop's own
            decel = ctx.controller.rest_decel if gentle else self.config.max_decel_rad_s2
            ctx.controller.brake(q, qd, decel)
        self.gentle = gentle
        self.lock_at_rest = brake and not gentle
        self.locked = False
        # a motor that does not deliver what it is commanded cannot brake its joint: its
        # holding brake does, from the start
        weak = np.abs(ctx.controller.tau - ctx.joint_torque) > WEAK_MOTOR_NM
        for j in np.flatnonzero(weak):
            self._engage(int(j), "its motor does not deliver the commanded torque")
        self.active = True
        self.reason = reason
        self.start_t = ctx.t
        self.stop_time_s = None
        self._still_steps = 0
        self.distance_m = 0.0
        x, y, z = self._tcp.tolist()
        self._last_tcp = (x, y, z)
        if not gentle:
            self.tcp_speed_m_s = _tcp_speed(ctx)
            true_qd = ctx.data.qvel[ctx.world.arm_dof]
            self.distance_min_m = profile_distance_m(
                self.tcp_speed_m_s, true_qd, self.config.max_decel_rad_s2
            )
            # the run's metrics name the abort's stop (an escalation's replaces the first)
            ctx.metrics["stop_speed_m_s"] = round(self.tcp_speed_m_s, 4)
            ctx.metrics["stop_distance_min_mm"] = round(self.distance_min_m * 1000.0, 3)

    def step(self) -> None:
        """One physics step of the stop: its travel, its monitoring, its end."""
        x, y, z = self._tcp.tolist()
        lx, ly, lz = self._last_tcp
        self.distance_m += math.sqrt((x - lx) ** 2 + (y - ly) ** 2 + (z - lz) ** 2)
        self._last_tcp = (x, y, z)
        ctx = self.ctx
        qd = ctx.data.qvel[ctx.world.arm_dof]
        ctrl = ctx.controller
        # a joint faster than its braking profile allows, or drifting from where it is held
        over = np.abs(qd) - np.abs(ctrl.brake_profile_velocity) > BRAKE_OVERSPEED_RAD_S
        drift = np.abs(ctrl.q_d - ctx.data.qpos[ctx.world.arm_qpos]) > BRAKE_TRACKING_RAD
        for j in np.flatnonzero(over | drift):
            self._engage(int(j), f"it does not follow its braking profile ({qd[j]:.3f} rad/s)")
        if ctrl.brake_left_s > 0.0:
            return
        if self.lock_at_rest and not self.locked:
            # the profile has brought the commanded speed to zero: the drives hand the arm
            # to the brakes (SS1): held by the motors' impedance alone, an arm that hit an
            # obstacle at 1 m/s swung back and forth at 0.02-0.06 rad/s for 170 ms more
            self._lock()
        if float(np.max(np.abs(qd))) >= self.config.rest_speed_rad_s:
            self._still_steps = 0
            return
        self._still_steps += 1
        if self._still_steps >= REST_STEPS:
            self.stop_time_s = ctx.t - self.start_t
            self.active = False

    def release(self) -> None:
        """Hand the stopped arm back to the motors (an `on_abort` response is about to move
        it): the brakes of the category-1 stop are released; those of joints whose motor
        failed stay engaged."""
        if self.locked:
            self.ctx.world.release_brakes(keep=self.braked_joints)
            self.locked = False
            self.ctx.log("safety", "holding brakes released: the motors hold the arm")

    def _lock(self) -> None:
        """The profile has ended: every joint's holding brake takes the arm (category 1)."""
        world = self.ctx.world
        for j in range(self.ctx.robot.n_arm):
            if j not in world.braked:
                world.engage_brake(j)
        self.locked = True
        self.ctx.log("safety", "holding brakes engaged on every joint: the arm is stopped")

    def _engage(self, joint: int, why: str) -> None:
        if joint in self.braked_joints:
            return
        self.braked_joints.append(joint)
        self.ctx.world.engage_brake(joint)
        self.ctx.log("safety", f"joint {joint + 1} holding brake engaged: {why}", level="WARN")

    def timed_out(self) -> bool:
        """The stop has taken longer than `max_stop_s`."""
        return self.active and self.ctx.t - self.start_t >= self.config.max_stop_s


def _tcp_speed(ctx: Context) -> float:
    """The TCP's linear speed now [m/s] (MuJoCo's site velocity, world frame)."""
    vel = np.zeros(6)
    mujoco.mj_objectVelocity(
        ctx.model, ctx.data, mujoco.mjtObj.mjOBJ_SITE, ctx.world.tcp_site, vel, 0
    )
    return float(np.linalg.norm(vel[3:]))
