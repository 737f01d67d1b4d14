"""Pause and resume: the skills' clock slows to a stop along the path, holds, and speeds up.

A `pause` does not brake the arm off its path: it scales the skills' clock (the time every
skill and state timeout measures durations on) from 1 down to 0 over `RAMP_S`, so a move
decelerates *along* its own path, exactly as a time-scaled trajectory does (the IK's joint
limiter keeps every joint inside its limits). At rate 0 no skill steps, timeouts stand still
and the controller holds the commanded pose. A `resume` ramps the rate back up from where the
arm is held (the skills keep stepping on the frozen clock until the arm is at rest, so the
command catches up with the stopped reference, then the controller holds that command).
The ramps are symmetric, so a pause of `D` seconds (event to event) delays the
run by `D` seconds of simulated time, up to a control tick.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from .context import Context

__all__ = ["RAMP_S", "REST_SPEED_RAD_S", "SETTLE_MAX_S", "PauseControl"]

RAMP_S = 0.25
"""Time the skills' clock takes to slow from full speed to a stop, or back [s]."""
REST_SPEED_RAD_S = 0.005
"""Every arm joint slower than this: the arm is at rest and the pause holds it [rad/s]."""
SETTLE_MAX_S = 1.0
"""Longest the skills may take to bring the arm to rest on the frozen clock [s]."""


class PauseControl:
    """The rate of the skills' clock and the hold while paused.

    Args:
        ctx: The episode context (its `clock_offset` accumulates the time held).
    """

    def __init__(self, ctx: Context) -> None:
        self.ctx = ctx
        self.rate = 1.0
        """Speed of the skills' clock: 1 running, 0 held, in between while ramping."""
        self.target = 1.0
        """1 after a resume (or never paused), 0 after a pause."""
        self.held = False
        """The rate reached 0: no skill steps, the controller holds the pose."""
        self._step = ctx.dt_control / RAMP_S
        self._hold_tcp: np.ndarray | None = None
        self._settle_ticks = 0
        self.pauses: list[dict[str, Any]] = []
        """One record per pause: `{t, held_t, resume_t, drift_mm}` (the TCP's largest
        distance from where it was when the hold began)."""

    @property
    def paused(self) -> bool:
        """A pause is in effect (ramping down or held) and no resume has come yet."""
        return self.target == 0.0

    def pause(self) -> None:
        self.target = 0.0
        self._settle_ticks = 0
        self.pauses.append(
            {"t": round(self.ctx.t, 6), "held_t": None, "resume_t": None, "drift_mm": 0.0}
        )

    def resume(self) -> None:
        self.target = 1.0
        if self.pauses:
            self.pauses[-1]["resume_t"] = round(self.ctx.t, 6)

    def cancel(self) -> None:
        """An abort: the safety response is never paused or slowed."""
        self.rate = self.target = 1.0
        self.held = False
        self.ctx.clock_rate = 1.0

    def tick(self) -> bool:
        """Advance the rate one control tick and the skills' clock with it.

        Returns:
            True if the skills step this tick, False while the pause holds them.
        """
        ctx = self.ctx
        if self.rate != self.target:
            if self.target < self.rate:
                self.rate = max(self.target, self.rate - self._step)
            else:
                self.rate = min(self.target, self.rate + self._step)
        ctx.clock_offset += (1.0 - self.rate) * ctx.dt_control
        ctx.clock_rate = self.rate
        if self.rate == 0.0:
            if not self.held:
                if not self._settled():
                    return True  # the skills bring their commands to rest on a frozen clock
                self._hold()
            self._measure_drift()
            return False
        if self.held:
            self._release()
        return True

    def _settled(self) -> bool:
        """The arm has come to rest (or has had `SETTLE_MAX_S` to), ready to be held."""
        ctx = self.ctx
        self._settle_ticks += 1
        speed = float(np.max(np.abs(ctx.qd)))
        return speed < REST_SPEED_RAD_S or self._settle_ticks * ctx.dt_control >= SETTLE_MAX_S

    def _hold(self) -> None:
        ctx = self.ctx
        self.held = True
        # the arm is at rest on its command: holding the command keeps that equilibrium (a
        # payload the controller's model lacks would sag away from a measured pose)
        ctx.controller.hold(ctx.controller.q_d.copy())
        self._hold_tcp = ctx.tcp_pos.copy()
        if self.pauses:
            self.pauses[-1]["held_t"] = round(ctx.t, 6)
        ctx.log("event", "paused: the arm holds its pose")

    def _release(self) -> None:
        ctx = self.ctx
        self.held = False
        self._hold_tcp = None
        ik = getattr(ctx, "ik", None)
        if ik is not None:  # the limited command restarts at rest from the held setpoint
            ik.restart_from(ctx.controller.q_d.copy())

    def _measure_drift(self) -> None:
        if self._hold_tcp is None or not self.pauses:
            return
        d = self.ctx.tcp_pos - self._hold_tcp
        mm = 1000.0 * math.sqrt(float(d @ d))
        rec = self.pauses[-1]
        if mm > rec["drift_mm"]:
            rec["drift_mm"] = round(mm, 4)
