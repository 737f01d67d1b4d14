"""The wrist force sensor as the robot's software reads it: MuJoCo's raw reading in the world
frame, the hand's weight removed, its noise and drift (`physics.realism`) and an injected fault.

Two readings are taken every physics step: the measured force's squared norm (the guards) and
the true one's (the run's peak force, ground truth). Both are computed in C where the compiled
module is built (world/native.py) and the noise is compiled too, else in Python; the choice is
made once, here, when the sensor is built, and holds for its life. A fault does not change
it: on the compiled path the C reader hands the measured reading to `_faulted_norm_sq` while a
fault acts (its own per-instant cache stays in C), on the Python path the fault is applied in
line. Either path gives the same floats, bit for bit (tests/test_native.py).

The sensor lives as long as the world (engine/cell.py): its bias (`zero`), its noise stream
and its fault carry over from one live task to the next.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np

from .native import native
from .realism import WristForceNoise
from .sensors import WristForceFault

if TYPE_CHECKING:
    from .step_clock import StepClock
    from .world import World

__all__ = ["WristSensor"]

Vec3 = tuple[float, float, float]


class WristSensor:
    """The wrist force/torque sensor's force channel, world frame [N].

    Args:
        world: The world (its sensor's address, the wrist site, the hand's weight and bias).
        clock: The world's step clock: readings are cached per simulated instant.
        noise: Noise and drift of the sensor, if `physics.realism` turns them on.
        status: A one-element view the sensor writes 1.0 into while a fault acts, 0.0
            otherwise (read by `sensor_health`'s envelope).

    Attributes:
        noise: The sensor's noise and drift (None: a noise-free sensor).
        compiled: The C reader (world/native.py `WristForce`), None on the Python path.
        norm_sq: Squared norm of the measured force [N^2], cached per instant: the C reader's
            method or the Python one, chosen at construction (a guard's envelope may hand the
            C one to the compiled envelope test, guards/bank.py).
        true_norm_sq: Squared norm of the true external force [N^2]: the noise-free sensor with
            the true weight of the hand and its tool removed (a perfect zero). Ground truth.
    """

    def __init__(
        self,
        world: World,
        clock: StepClock,
        noise: WristForceNoise | None,
        status: np.ndarray,
    ) -> None:
        d = world.data
        self.world = world
        self.clock = clock
        self.noise = noise
        self._status = status
        self._fault: WristForceFault | None = None
        # The raw reading and the rotation of its site, read every physics step as plain
        # floats: a 3x3 matrix-vector product in numpy costs more in call overhead than in
        # arithmetic.
        self._f_site = d.sensordata[world.force_adr : world.force_adr + 3]
        self._wrist_rot = d.site_xmat[world.wrist_site]
        self._bias: tuple[float, ...] = tuple(world.wrist_bias_world.tolist())
        """`world.wrist_bias_world` as floats (only `zero` changes it)."""
        self._true_weight: tuple[float, ...] = tuple(world.wrist_weight_world.tolist())
        """`world.wrist_weight_world` as floats: the true weight of the hand and its tool."""
        self._norm_sq_t = -1.0
        self._norm_sq = 0.0
        self._sensed_t = math.nan
        self._sensed: Vec3 = (0.0, 0.0, 0.0)
        ext = native()
        self.compiled: Any = None
        self.norm_sq: Callable[[], float] = self._py_norm_sq
        self.true_norm_sq: Callable[[], float] = self._py_true_norm_sq
        if ext is not None and (noise is None or noise.compiled is not None):
            self.compiled = ext.WristForce(
                clock,
                self._f_site,
                self._wrist_rot,
                self._bias,
                self._true_weight,
                None if noise is None else noise.compiled,
            )
            # the two readings of every physics step, one C call each
            self.norm_sq = self.compiled.norm_sq
            self.true_norm_sq = self.compiled.true_norm_sq

    # -- the fault ------------------------------------------------------------------------
    @property
    def fault(self) -> WristForceFault | None:
        """An injected fault of the sensor, if any."""
        return self._fault

    @fault.setter
    def fault(self, fault: WristForceFault | None) -> None:
        self._fault = fault
        self._status[0] = 0.0 if fault is None else 1.0
        self._norm_sq_t = -1.0  # the fault acts from now on: a new reading
        if self.compiled is not None:  # the C reading hands over to Python while a fault acts
            self.compiled.set_fallback(None if fault is None else self._faulted_norm_sq)

    def age_s(self) -> float:
        """Time since the reading last updated [s] (its timestamp; 0 when live)."""
        return 0.0 if self._fault is None else self._fault.age_s(self.clock.t)

    # -- readings -------------------------------------------------------------------------
    def force(self, now: float | None = None) -> Vec3:
        """The measured force at simulated time `now` [s] (None: now), hand weight removed."""
        if now is None:
            now = self.clock.t
        if self.compiled is not None:
            f = self.compiled.measured(now)
            return f if self._fault is None else self._fault.apply(f, now)
        rx, ry, rz = self._sensed_world(now)
        bx, by, bz = self._bias
        f = (bx - rx, by - ry, bz - rz)
        if self.noise is not None:
            f = self.noise.apply(f, now)
        if self._fault is not None:
            return self._fault.apply(f, now)
        return f

    def true_force(self) -> Vec3:
        """The true external force on the wrist now [N] (see `true_norm_sq`)."""
        rx, ry, rz = self._sensed_world(self.clock.t)
        bx, by, bz = self._true_weight
        return (bx - rx, by - ry, bz - rz)

    def zero(self, offset: np.ndarray) -> None:
        """Remove `offset` [N] (world frame, shape (3,)) from every later reading."""
        self.world.wrist_bias_world -= np.asarray(offset, dtype=float)
        self._bias = tuple(self.world.wrist_bias_world.tolist())
        self._norm_sq_t = -1.0
        if self.compiled is not None:
            self.compiled.set_bias(self._bias)

    # -- the Python path ------------------------------------------------------------------
    def _py_norm_sq(self) -> float:
        """`norm_sq` in Python: `force` written out (every physics step, where every call and
        attribute lookup counts: the caches are cold after mj_step)."""
        now = self.clock.t
        if now == self._norm_sq_t:
            return self._norm_sq
        rx, ry, rz = self._sensed if now == self._sensed_t else self._sensed_world(now)
        bx, by, bz = self._bias
        fx, fy, fz = bx - rx, by - ry, bz - rz
        noise = self.noise
        if noise is not None:
            ox, oy, oz = noise.offset(now)
            fx, fy, fz = fx + ox, fy + oy, fz + oz
        if self._fault is not None:
            fx, fy, fz = self._fault.apply((fx, fy, fz), now)
        norm_sq = fx * fx + fy * fy + fz * fz
        self._norm_sq, self._norm_sq_t = norm_sq, now
        return norm_sq

    def _py_true_norm_sq(self) -> float:
        """`true_norm_sq` in Python."""
        rx, ry, rz = self._sensed_world(self.clock.t)
        bx, by, bz = self._true_weight
        fx, fy, fz = bx - rx, by - ry, bz - rz
        return fx * fx + fy * fy + fz * fz

    def _faulted_norm_sq(self) -> float:
        """`norm_sq` on the compiled path while a fault acts (the C reader calls it and caches
        the result for the instant)."""
        now = self.clock.t
        fx, fy, fz = self.compiled.measured(now)
        if self._fault is not None:
            fx, fy, fz = self._fault.apply((fx, fy, fz), now)
        return fx * fx + fy * fy + fz * fz

    def _sensed_world(self, now: float) -> Vec3:
        """The raw reading rotated into the world frame [N] at simulated time `now` [s],
        computed once per instant: the true force and the measured one share it."""
        if self.compiled is not None:
            return self.compiled.sensed(now)  # type: ignore[no-any-return]
        if now == self._sensed_t:
            return self._sensed
        f0, f1, f2 = self._f_site.tolist()
        r0, r1, r2, r3, r4, r5, r6, r7, r8 = self._wrist_rot.tolist()
        sensed = (
            r0 * f0 + r1 * f1 + r2 * f2,
            r3 * f0 + r4 * f1 + r5 * f2,
            r6 * f0 + r7 * f1 + r8 * f2,
        )
        self._sensed, self._sensed_t = sensed, now
        return sensed
