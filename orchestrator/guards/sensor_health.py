"""`sensor_health`: the sensors and drives the controller relies on are healthy.

* Wrist force/torque sensor: its reading must be finite, within the sensor's measuring range,
  and fresh (its timestamp advances: a dropped-out sensor repeats a stale value).
* Joint encoders: each must agree with the joint's independent safety encoder (a frozen,
  noisy or dead encoder disagrees as soon as the joint moves).
* Joint torque sensors: each joint's motor delivers the torque it was commanded (a drive that
  dropped out or a derated motor delivers less).
"""

from __future__ import annotations

import math
import sys
from typing import TYPE_CHECKING, ClassVar

from pydantic import Field, PositiveFloat

from .base import Envelope, Guard, GuardParams, Violation

if TYPE_CHECKING:
    from ..engine.context import Context

__all__ = ["SensorHealth"]


class SensorHealthParams(GuardParams):
    ft_range_n: PositiveFloat = Field(
        default=100.0, le=1e4, description="Measuring range of the wrist force sensor [N]."
    )
    ft_stale_ms: PositiveFloat = Field(
        default=10.0, le=1e4, description="Longest a wrist force reading may stay unchanged [ms]."
    )
    torque_tolerance_nm: PositiveFloat = Field(
        default=0.5,
        le=100.0,
        description="Largest difference between a joint's commanded and measured torque [Nm].",
    )
    encoder_tolerance_rad: PositiveFloat = Field(
        default=0.01,
        le=1.0,
        description="Largest disagreement of a joint encoder with its safety encoder [rad].",
    )


class SensorHealth(Guard):
    """Fires on a non-finite, out-of-range or stale wrist force reading, a joint motor that
    does not deliver its commanded torque (by `torque_tolerance_nm`), or a joint encoder that
    disagrees with its safety encoder by more than `encoder_tolerance_rad`."""

    name: ClassVar[str] = "sensor_health"
    Params: ClassVar[type[GuardParams]] = SensorHealthParams
    priority: ClassVar[int] = 3
    """Before the guards that act on these readings: a bad reading is a sensor fault first."""

    params: SensorHealthParams

    def bind(self, ctx: Context) -> None:
        p = self.params
        self._range_sq = p.ft_range_n * p.ft_range_n
        self._stale_s = p.ft_stale_ms / 1000.0
        self._tol = p.encoder_tolerance_rad
        self._n = ctx.robot.n_arm
        self._safety_q = ctx.data.qpos[ctx.world.arm_qpos_index]  # a view: never reallocated
        self._commanded = ctx.controller.tau  # the controller writes into this array
        self._measured = ctx.data.actuator_force[ctx.world.arm_act_index]
        self._tau_tol = p.torque_tolerance_nm

    def check(self, ctx: Context) -> Violation | None:
        norm_sq = ctx.wrist_force_norm_sq()
        if not norm_sq <= self._range_sq:  # NaN compares false too
            return self._ft(norm_sq)
        age = ctx.wrist_force_age_s()
        if age > self._stale_s:
            return Violation(
                self.name,
                f"wrist force sensor stale: no new reading for {age * 1000:.0f} ms",
                round(age * 1000, 3),
                self.params.ft_stale_ms,
            )
        commanded, measured = self._commanded.tolist(), self._measured.tolist()
        if commanded != measured:  # equal floats in normal operation: the fast path
            tau_tol = self._tau_tol
            for i, (a, b) in enumerate(zip(commanded, measured, strict=True)):
                if not abs(a - b) <= tau_tol:
                    return Violation(
                        self.name,
                        f"joint {i + 1} motor delivers {b:.1f} Nm of the {a:.1f} Nm commanded",
                        round(b, 3),
                        round(a, 3),
                    )
        safety = self._safety_q.tolist()
        encoders = ctx.cell.encoders
        if encoders.fault is None or encoders.failed_over:
            # the primary channel reads the safety channel's values: they can only disagree
            # by a NaN (NaN != NaN), which makes the sum NaN; compare in full only then
            total = sum(safety)
            if not math.isnan(total):
                return None
        primary = encoders.read()[0][: self._n].tolist()
        if primary != safety:
            tol = self._tol
            for i, (a, b) in enumerate(zip(primary, safety, strict=True)):
                if not abs(a - b) <= tol:
                    return self._encoder(i, a, b)
        return None

    def envelope(self, ctx: Context) -> Envelope | None:
        w = ctx.world
        if not (isinstance(w.arm_qpos_index, slice) and isinstance(w.arm_act_index, slice)):
            return None  # the readings are copies, not views
        big = sys.float_info.max
        n = self._n
        return Envelope(
            bounds=(
                # a sensor fault (a stale or disagreeing channel) makes `check` decide
                (ctx.cell.sensor_faults, [0.0, 0.0], [0.0, 0.0]),
                # the safety encoders finite (NaN or inf: `check` decides)
                (self._safety_q, [-big] * n, [big] * n),
            ),
            equal=((self._commanded, self._measured),),  # every motor delivers its command
            scalars=((ctx.wrist_force_norm_sq, self._range_sq),),
        )

    def _ft(self, norm_sq: float) -> Violation:
        if not math.isfinite(norm_sq):
            return Violation(self.name, "wrist force sensor reads a non-finite value", None, None)
        norm = math.sqrt(norm_sq)
        return Violation(
            self.name,
            f"wrist force {norm:.1f} N is beyond the sensor's range {self.params.ft_range_n} N",
            round(norm, 3),
            self.params.ft_range_n,
        )

    def _encoder(self, i: int, a: float, b: float) -> Violation:
        if not math.isfinite(a):
            return Violation(self.name, f"joint {i + 1} encoder reads a non-finite value", None, 0)
        diff = abs(a - b)
        return Violation(
            self.name,
            f"joint {i + 1} encoder ({a:.4f} rad) disagrees with its safety encoder "
            f"({b:.4f} rad) by {diff:.4f} rad",
            round(diff, 6),
            self._tol,
        )

    def monitored(self, ctx: Context) -> tuple[float, float]:
        return math.sqrt(ctx.wrist_force_norm_sq()), self.params.ft_range_n
