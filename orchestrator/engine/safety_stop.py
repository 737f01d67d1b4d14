"""The controlled stop: brake the arm to standstill under control, hold it, and measure it.

Every abort (a guard, an e-stop), and every end of a run, goes through it. It is judged by the
arm, not the log: the stop is over when the braking profile has ended and every arm joint
moves slower than `rest_speed_rad_s`, measured every physics step on MuJoCo's state.

The stop is monitored like a safe stop 1 (SS1) of a safety controller: a joint that does not
follow its braking profile (its motor is lost or too weak) gets its holding brake.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from ..language.scenario import SafeStop
    from .context import Context

__all__ = ["BRAKE_TRACKING_RAD", "SafetyStop"]

BRAKE_TRACKING_RAD = 0.05
"""A held joint this far from where it is held gets its holding brake [rad]."""
WEAK_MOTOR_NM = 0.5
"""A motor delivering this much less than commanded when the stop starts is braked [Nm]."""
BRAKE_OVERSPEED_RAD_S = 0.3
"""A joint this much faster than its braking profile allows gets its holding brake [rad/s]."""


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
        self.braked_joints: list[int] = []
        self._last_tcp = (0.0, 0.0, 0.0)

    @property
    def at_rest(self) -> bool:
        """The stop has ended: the arm is still and held."""
        return self.stop_time_s is not None

    def start(self, reason: str, gentle: bool = False) -> None:
        """Brake from the measured state (read on the safety encoders).

        Args:
            reason: Why (for the log).
            gentle: At the robot's own acceleration limits (the end of a run, a normal stop)
                rather than at the safety stop's `max_decel_rad_s2` (an abort).
        """
        ctx = self.ctx
        if not gentle:
            ctx.encoders.failover()
        q, qd = ctx.encoders.safety_channel()
        n = ctx.robot.n_arm
        if gentle and float(np.max(np.abs(qd[:n]))) < self.config.rest_speed_rad_s:
            ctx.controller.hold_setpoint()  # already still: keep its setpoint (brought to rest)
        else:
            # a normal stop within the limits the commands keep to (the arm overshoots a
            # profile at the datasheet limit by ~20 %); an abort at the safety stop's own
            decel = ctx.controller.rest_decel if gentle else self.config.max_decel_rad_s2
            ctx.controller.brake(q, qd, decel)
        # a motor that does not deliver what it is commanded cannot brake its joint: its
        # holding brake does, from the start
        weak = np.abs(ctx.controller.tau - ctx.joint_torque) > WEAK_MOTOR_NM
        for j in np.flatnonzero(weak):
            self._engage(int(j), "its motor does not deliver the commanded torque")
        self.active = True
        self.reason = reason
        self.start_t = ctx.t
        self.stop_time_s = None
        self.distance_m = 0.0
        x, y, z = self._tcp.tolist()
        self._last_tcp = (x, y, z)

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
        if ctrl.brake_left_s <= 0.0 and float(np.max(np.abs(qd))) < self.config.rest_speed_rad_s:
            self.stop_time_s = ctx.t - self.start_t
            self.active = False

    def _engage(self, joint: int, why: str) -> None:
        if joint in self.braked_joints:
            return
        self.braked_joints.append(joint)
        self.ctx.world.engage_brake(joint)
        self.ctx.log("safety", f"joint {joint + 1} holding brake engaged: {why}", level="WARN")

    def timed_out(self) -> bool:
        """The stop has taken longer than `max_stop_s`."""
        return self.active and self.ctx.t - self.start_t >= self.config.max_stop_s
