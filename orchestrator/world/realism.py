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
from typing import TYPE_CHECKING

import mujoco
import numpy as np

from .native import native

if TYPE_CHECKING:
    from ..language.scenario import Realism
    from ..robots import Robot

__all__ = ["WristForceNoise", "apply_joint_friction", "link_mass_scale"]

MASS_SEED = 0x3A55
"""Stream id of the model-mismatch draw (with the episode seed)."""
FT_SEED = 0xF7
"""Stream id of the wrist sensor's noise (with the episode seed)."""


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
    rng = np.random.default_rng([seed, MASS_SEED])
    x = realism.mass_mismatch
    return rng.uniform(1.0 - x, 1.0 + x, size=n_bodies)


_BLOCK = 512
"""Readings of the wrist force noise drawn at a time."""


class WristForceNoise:
    """Noise and bias drift of the wrist force sensor, per axis, in the world frame [N].

    A new sample is drawn when the simulated time moves on (every physics step a reading is
    taken); readings within one step agree. The bias is a random walk of
    `drift_n_per_sqrt_s * sqrt(dt)` per step: zeroing the sensor removes what it has drifted
    to, not what it will drift to.

    Args:
        std_n: White noise, standard deviation per axis per reading [N].
        drift_n_per_sqrt_s: Bias random walk [N/sqrt(s)].
        seed: Episode seed.
    """

    def __init__(self, std_n: float, drift_n_per_sqrt_s: float, seed: int) -> None:
        self.std = float(std_n)
        self.drift = float(drift_n_per_sqrt_s)
        self.rng = np.random.default_rng([seed, FT_SEED])
        self._draws: list[tuple[float, ...]] = []
        """Normal samples drawn ahead, six per reading (white noise x, y, z, then the drift's
        steps x, y, z), in blocks of `_BLOCK` readings: the stream is the same as drawing six
        per reading (a Generator fills an array one sample after another), at a fraction of
        the cost of a numpy call every physics step."""
        self._next = 0
        self._bias = [0.0, 0.0, 0.0]
        self._t = math.nan
        self._offset = (0.0, 0.0, 0.0)
        ext = native()
        self.compiled = (
            # the refill reads the generator, not this object: no reference cycle to collect
            ext.FtNoise(self.std, self.drift, partial(self.rng.standard_normal, _BLOCK * 6))
            if ext is not None
            else None
        )
        """The same stream computed in C (world/native.py), None on the pure-Python path:
        `offset` then hands over to it."""
        if self.compiled is not None:
            self.offset = self.compiled.offset  # type: ignore[method-assign]

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
        # runs every physics step while a guard reads the wrist force: no list is built here
        dt = 0.0 if math.isnan(self._t) else t - self._t  # the first reading walks no drift
        if dt < 0.0:  # noqa: PLR1730 (cheaper than max() per step)
            dt = 0.0
        k = self._next
        draws = self._draws
        if k == len(draws):
            flat = self.rng.standard_normal(_BLOCK * 6).tolist()
            draws = self._draws = list(zip(*[iter(flat)] * 6, strict=True))
            k = 0
        n0, n1, n2, n3, n4, n5 = draws[k]
        self._next = k + 1
        walk = self.drift * math.sqrt(dt)
        b = self._bias
        bx = b[0] = b[0] + walk * n3
        by = b[1] = b[1] + walk * n4
        bz = b[2] = b[2] + walk * n5
        s = self.std
        offset = self._offset = (bx + s * n0, by + s * n1, bz + s * n2)
        self._t = t
        return offset
