"""Plant realism: what makes the simulated robot less ideal than its model.

The scenario's `physics.realism` (on by default) turns on, from the robot's datasheet values:

* joint friction in the plant — Coulomb (MuJoCo's `frictionloss`, a dry-friction constraint)
  and viscous (`damping`), which the controller does not model or compensate;
* wrist force sensor noise and a random-walk bias drift (`WristForceNoise`, applied to every
  reading the software takes; the run's ground-truth metrics never see it);
* joint encoder quantization (`world/sensors.JointEncoders`: positions in encoder steps,
  velocities the difference of successive readings);
* controller model mismatch: the controller's link masses each off by a seeded factor
  (`link_mass_scale`).

Every random draw comes from a stream seeded by the episode seed: the run stays
deterministic.
"""

from __future__ import annotations

import math
from functools import partial
from typing import TYPE_CHECKING, Any

import mujoco
import numpy as np

from .native import native
from .random_streams import stream

if TYPE_CHECKING:
    from ..language.scenario import Realism
    from ..robots import Robot

__all__ = ["WristForceNoise", "apply_joint_friction", "link_mass_scale"]


def apply_joint_friction(
    model: mujoco.MjModel, robot: Robot, arm_dof: np.ndarray, realism: Realism
) -> None:
    """Give the arm's joints the robot's Coulomb and viscous friction (scaled)."""
    if not realism.enabled or realism.joint_friction_scale == 0.0:
        return
    scale = realism.joint_friction_scale
    if robot.joint_friction_nm is not None:
        model.dof_frictionloss[arm_dof] = scale * np.asarray(robot.joint_friction_nm, float)
    if robot.joint_damping_nms is not None:
        model.dof_damping[arm_dof] = scale * np.asarray(robot.joint_damping_nms, float)


def link_mass_scale(realism: Realism, n_bodies: int, seed: int) -> np.ndarray | None:
    """Factors on the masses (and inertias) of the controller's `n_bodies` moving links,
    uniform in [1 - x, 1 + x] for `x = realism.mass_mismatch`; None when off. Shape (n,)."""
    if not realism.enabled or realism.mass_mismatch == 0.0:
        return None
    rng = stream(seed, "mass_mismatch")
    x = realism.mass_mismatch
    return rng.uniform(1.0 - x, 1.0 + x, size=n_bodies)


_BLOCK = 512
"""Readings of the wrist force noise drawn at a time."""


_STREAM = ("_draws", "_next", "_k", "_tau", "_bias", "_t", "_offset")
"""What `WristForceNoise` holds of its stream (the rest is its configuration)."""


class WristForceNoise:
    """Noise and bias drift of the wrist force sensor, per axis, in the world frame [N].

    The noise a reading gets is a function of the physics step it is taken at, never of the
    readings before it: step k (k = 1, 2, ... since the episode started; `t / dt` rounded)
    gets the k-th of the seeded samples, and the bias is a random walk of
    `drift_n_per_sqrt_s * sqrt(dt)` per step elapsed (the first step walks none). Readings
    within one step agree; readings that skip steps walk the skipped steps' draws, so whoever
    reads the sensor, and when, the reading at a step is the one a guard reading every step
    sees (a reading at t = 0, before the first step, gets the first step's). Zeroing the
    sensor removes what it has drifted to, not what it will drift to.

    Args:
        std_n: White noise, standard deviation per axis per reading [N].
        drift_n_per_sqrt_s: Bias random walk [N/sqrt(s)].
        seed: Episode seed.
        dt: The physics timestep [s] (`MjModel.opt.timestep`): the world's `StepClock` is
            the sum of it, step by step, from 0.
    """

    def __init__(self, std_n: float, drift_n_per_sqrt_s: float, seed: int, dt: float) -> None:
        self.std = float(std_n)
        self.drift = float(drift_n_per_sqrt_s)
        self.dt = float(dt)
        self.rng = stream(seed, "wrist_noise")
        self._draws: list[tuple[float, ...]] = []
        """Normal samples drawn ahead, six per physics step (white noise x, y, z, then the
        drift's steps x, y, z), in blocks of `_BLOCK` steps: the stream is the same as drawing
        six per step (a Generator fills an array one sample after another), at a fraction of
        the cost of a numpy call every physics step."""
        self._next = 0
        self._k = 0
        """The physics step the bias has walked to (0: none drawn yet)."""
        self._tau = 0.0
        """Simulated time of step `_k` [s], summed as the step function sums it."""
        self._bias = [0.0, 0.0, 0.0]
        self._t = math.nan
        self._offset = (0.0, 0.0, 0.0)
        ext = native()
        self.compiled = (
            # the refill reads the generator, not this object: no reference cycle to collect
            ext.FtNoise(
                self.std, self.drift, self.dt, partial(self.rng.standard_normal, _BLOCK * 6)
            )
            if ext is not None
            else None
        )
        """The same stream computed in C (world/native.py), None on the pure-Python path:
        `offset` then hands over to it."""
        if self.compiled is not None:
            self.offset = self.compiled.offset  # type: ignore[method-assign]

    def snapshot_state(self) -> dict[str, Any]:
        """Where the stream is, as plain data (a run snapshot, engine/snapshot): the drift
        walked, the step it is at, the samples drawn ahead (and the compiled stream's own)."""
        state: dict[str, Any] = {name: getattr(self, name) for name in _STREAM}
        if self.compiled is not None:
            state["compiled"] = self.compiled.__reduce__()[2]
        return state

    def restore_state(self, data: dict[str, Any]) -> None:
        """Take back what `snapshot_state` recorded (the generator's own state is restored
        with every other generator of the run)."""
        compiled = data.get("compiled")
        for name in _STREAM:
            value = data[name]
            setattr(self, name, list(value) if isinstance(self.__dict__[name], list) else value)
        if self.compiled is not None:
            if not isinstance(compiled, tuple):
                raise ValueError("the wrist noise's compiled stream has no recorded state")
            self.compiled.__setstate__(compiled)

    @property
    def bias(self) -> list[float]:
        """The drift the bias has walked to [N], per axis."""
        return self._bias if self.compiled is None else self.compiled.bias

    def apply(self, f: tuple[float, float, float], t: float) -> tuple[float, float, float]:
        """The reading of a sensor that measures `f` [N] at simulated time `t` [s]."""
        ox, oy, oz = self.offset(t)
        return (f[0] + ox, f[1] + oy, f[2] + oz)

    def offset(self, t: float) -> tuple[float, float, float]:
        """What noise and drift add to a reading at simulated time `t` [s], per axis [N]."""
        if t == self._t:
            return self._offset
        self._t = t
        # the step t is at: a sum of k timesteps strays from k * dt by far less than half one
        k = math.floor(t / self.dt + 0.5)
        if k < 1:  # noqa: PLR1730 (cheaper than max() per step)
            # before the first step: the first step's sample
            k = 1
        j = self._k
        if j >= k:  # this step's sample, or a step back (the stream never runs backwards)
            return self._offset
        # runs every physics step while a guard reads the wrist force: no list is built here
        draws, i = self._draws, self._next
        b, tau, dt, drift = self._bias, self._tau, self.dt, self.drift
        n0 = n1 = n2 = 0.0
        while j < k:  # every step since the last sample, its six draws in order
            if i == len(draws):
                flat = self.rng.standard_normal(_BLOCK * 6).tolist()
                draws = self._draws = list(zip(*[iter(flat)] * 6, strict=True))
                i = 0
            n0, n1, n2, n3, n4, n5 = draws[i]
            i += 1
            nxt = tau + dt  # step j + 1's time, as the step function sums it
            walk = drift * math.sqrt(nxt - tau if j else 0.0)  # the first step walks none
            b[0] = b[0] + walk * n3
            b[1] = b[1] + walk * n4
            b[2] = b[2] + walk * n5
            tau = nxt
            j += 1
        self._next, self._k, self._tau = i, j, tau
        s = self.std
        offset = self._offset = (b[0] + s * n0, b[1] + s * n1, b[2] + s * n2)
        return offset
