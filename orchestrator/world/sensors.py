"""The robot's sensors as its software reads them: joint encoders and the wrist force sensor,
with the faults a scenario can inject into them.

Without a fault both read MuJoCo's state directly (views bound once, no copies): the physics
step pays nothing for the possibility of a fault. A fault swaps in a corrupted reading.

The joints also have a second, independent channel — the safety encoders a safety controller
reads (the simulated ground truth stands in for it). `sensor_health` compares the two, and
after any abort the controller switches to the safety channel (`failover`), as a real robot
brakes on its safety encoders when its primary ones are suspect.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from .pose import Pose

if TYPE_CHECKING:
    from .step_clock import StepClock

__all__ = ["JointEncoders", "PerceptionFaults", "WristForceFault"]


class JointEncoders:
    """Positions and velocities of the robot's joints (arm, then fingers) as the controller
    reads them.

    Args:
        qpos: The robot's joint positions in MjData (a view or an index-copy source).
        qvel: The robot's joint velocities.
        q_index: Index of the robot's joints in `qpos` (a slice when contiguous).
        v_index: Index of the robot's dofs in `qvel`.
        n_arm: Number of arm joints (faults address arm joints 1..n_arm).
        rng: Random stream of encoder noise (seeded per episode).
        resolution_rad: Encoder step [rad]; 0 reads the exact state. Above 0, positions are
            rounded to it and velocities are the difference of the last two readings over
            the time between them, low-pass filtered (as a drive estimates them), once per
            simulated instant.
        clock: The world's simulated time (`StepClock`, read as `clock.t` [s]; needed when
            `resolution_rad` > 0).
        velocity_filter_hz: Cut-off of the first-order filter on the differenced velocity.
        status: Where to flag a fault (shape (1,), written in place): 1.0 while a fault is
            injected and the safety channel has not taken over, else 0.0 — a reading a
            guard's envelope watches without a Python call. Default: an array of its own.
    """

    def __init__(
        self,
        qpos: np.ndarray,
        qvel: np.ndarray,
        q_index: slice | np.ndarray,
        v_index: slice | np.ndarray,
        n_arm: int,
        rng: np.random.Generator,
        resolution_rad: float = 0.0,
        clock: StepClock | None = None,
        velocity_filter_hz: float = 100.0,
        status: np.ndarray | None = None,
    ) -> None:
        self._qpos, self._qvel = qpos, qvel
        self._qi, self._vi = q_index, v_index
        self._truth = (qpos[q_index], qvel[v_index])
        """Views when the indices are slices (bound once: MjData never reallocates); copies
        otherwise, refreshed by `read`."""
        self._views = isinstance(q_index, slice) and isinstance(v_index, slice)
        self.n_arm = n_arm
        self.rng = rng
        self.fault: str | None = None
        """Active fault kind (`encoder_freeze`, `encoder_noise`, `encoder_nan`) or None."""
        self.joint = -1
        self.std = 0.0
        self._frozen: tuple[float, float] = (0.0, 0.0)
        self.failed_over = False
        self.status = status if status is not None else np.zeros(1)
        self.status[0] = 0.0
        self.resolution = float(resolution_rad)
        if self.resolution > 0.0 and clock is None:
            raise ValueError("quantized encoders need a clock")
        self._clock = clock
        self._res = np.array(self.resolution)
        self._dt = np.zeros(())
        self._gain = np.zeros(())
        self._dt_last = math.nan
        """0-d scalars of the quantization's arithmetic (cheaper operands than floats)."""
        self._omega = 2.0 * math.pi * velocity_filter_hz
        self._read_t = math.nan
        self._measured: tuple[np.ndarray, np.ndarray] = self._truth

    def read(self) -> tuple[np.ndarray, np.ndarray]:
        """Joint positions [rad] and velocities [rad/s], arm then fingers."""
        if self.failed_over or (self.fault is None and self.resolution == 0.0):
            if not self._views:
                self._truth = (self._qpos[self._qi], self._qvel[self._vi])
            return self._truth
        q, v = self._quantized() if self.resolution > 0.0 else self._exact()
        if self.fault is None:
            return q, v
        q, v = q.copy(), v.copy()
        j = self.joint
        if self.fault == "encoder_freeze":
            q[j], v[j] = self._frozen
        elif self.fault == "encoder_noise":
            q[j] += self.rng.normal(0.0, self.std)
        else:
            q[j] = v[j] = math.nan
        return q, v

    def _exact(self) -> tuple[np.ndarray, np.ndarray]:
        return self._qpos[self._qi].copy(), self._qvel[self._vi].copy()

    def _quantized(self) -> tuple[np.ndarray, np.ndarray]:
        assert self._clock is not None
        now = self._clock.t
        if now == self._read_t:
            return self._measured
        # Each numpy call on a 12-vector costs ~1 us (a Python float operand ~0.5 us more):
        # in-place ufuncs on 0-d array scalars, the same operations in the same order as
        # round(x / res) * res and m1 + k (raw - m1), so the readings are bit for bit those.
        res = self._res
        q = np.divide(self._truth[0] if self._views else self._qpos[self._qi], res)
        np.rint(q, out=q)  # np.round with 0 decimals is rint: half to even
        np.multiply(q, res, out=q)
        if math.isnan(self._read_t) or now <= self._read_t:
            v = np.divide(self._qvel[self._vi], res)  # no earlier reading to difference
            np.rint(v, out=v)
            np.multiply(v, res, out=v)
        else:
            dt = now - self._read_t
            q0, v0 = self._measured
            if dt != self._dt_last:  # nearly always the last step's: skip 2 writes, an exp
                self._dt_last = dt
                self._dt[()] = dt
                self._gain[()] = 1.0 - math.exp(-self._omega * dt)
            v = np.subtract(q, q0)
            np.divide(v, self._dt, out=v)  # the raw differenced velocity
            np.subtract(v, v0, out=v)
            np.multiply(self._gain, v, out=v)
            np.add(v0, v, out=v)  # the filtered one
        self._measured = (q, v)
        self._read_t = now
        return self._measured

    def safety_channel(self) -> tuple[np.ndarray, np.ndarray]:
        """The independent safety encoders: the true joint state. Never faulty."""
        return self._truth

    def inject(self, kind: str, joint: int, std_rad: float = 0.0) -> None:
        """Start a fault on arm joint `joint` (1-based)."""
        if not 1 <= joint <= self.n_arm:
            raise ValueError(f"joint {joint} is not an arm joint (1..{self.n_arm})")
        self.fault, self.joint, self.std = kind, joint - 1, std_rad
        self.status[0] = 0.0 if self.failed_over else 1.0
        q, v = self._qpos[self._qi], self._qvel[self._vi]
        self._frozen = (float(q[self.joint]), float(v[self.joint]))

    def failover(self) -> None:
        """Read the safety channel from now on (after an abort)."""
        self.failed_over = True
        self.status[0] = 0.0


class WristForceFault:
    """A fault of the wrist force sensor, applied to each reading (world frame [N]).

    Attributes:
        kind: `ft_dropout`, `ft_bias`, `ft_spike` or `ft_nan`.
        start_t: Simulated time the fault started [s].
        end_t: When a spike ends [s] (inf for the others).
    """

    def __init__(
        self, kind: str, start_t: float, offset: tuple[float, float, float], end_t: float
    ) -> None:
        self.kind, self.start_t, self.end_t = kind, start_t, end_t
        self.offset = offset
        self.latched: tuple[float, float, float] | None = None

    def apply(self, f: tuple[float, float, float], t: float) -> tuple[float, float, float]:
        """The reading the software gets at time `t` when the sensor measures `f`."""
        if self.kind == "ft_nan":
            return (math.nan, math.nan, math.nan)
        if self.kind == "ft_dropout":
            if self.latched is None:
                self.latched = f
            return self.latched
        if t >= self.end_t:
            return f
        ox, oy, oz = self.offset
        return (f[0] + ox, f[1] + oy, f[2] + oz)

    def age_s(self, t: float) -> float:
        """Time since the reading last updated [s] (the sensor's timestamp)."""
        return t - self.start_t if self.kind == "ft_dropout" else 0.0


class PerceptionFaults:
    """What goes wrong with perception: misses and offsets, applied to each reported pose.

    Every perception skill (the `search` oracle, the camera `detect`) passes what it reports
    through `observe`, so a scenario's `perception_miss` / `perception_offset` faults reach all
    of them the same way.
    """

    def __init__(self) -> None:
        self.misses = 0
        self.offset = np.zeros(3)
        self.offset_left: int | None = 0
        """Calls the offset still applies to (None: every later call)."""

    def miss(self, count: int) -> None:
        self.misses += count

    def shift(self, offset_m: np.ndarray, count: int | None) -> None:
        self.offset = np.asarray(offset_m, float)
        self.offset_left = count

    def observe(self, pose: Pose) -> Pose | None:
        """The pose perception reports for `pose` (None: it found nothing)."""
        if self.misses:
            self.misses -= 1
            return None
        if self.offset_left == 0:
            return pose
        if self.offset_left is not None:
            self.offset_left -= 1
        return Pose(pos=(np.asarray(pose.pos) + self.offset).tolist(), quat=list(pose.quat))

    @property
    def active(self) -> bool:
        return bool(self.misses) or self.offset_left != 0
