"""Slow a Cartesian motion down, as a whole, until the joints can follow it.

A move's straight line with its trapezoidal timing says nothing about the joints: near the
arm's limits of reach, or with a brisk `max_accel`, the IK would need joint velocities or
accelerations beyond the robot's. The joint limiter then clips each joint on its own, which
bends the TCP's path (a pre-grasp move dipped 7 cm below its target into the object, 6 of 200
pick_place seeds, before this existed). Instead, the IK reference of the whole motion is
computed once at the start (the IK integrates its own reference open loop, so this is exactly
the motion it will command), and time is stretched uniformly by the smallest factor that brings
every joint's velocity and acceleration within the limiter's: the path stays the same, only
slower, and the limiter only smooths the jerk.
"""

from __future__ import annotations

import math

import numpy as np

from .ik import IKSolver
from .trajectory import CartesianLine

__all__ = ["feasible_time_scale"]

MARGIN = 0.95
"""Fraction of the limiter's limits the stretched reference may use."""

STRIDE = 3
"""Control ticks per step of a dry run: a 30 ms step resolves the velocity and acceleration
of a move (whose ramps last 0.1 s and more) at a third of the cost of running every tick."""


def feasible_time_scale(
    ik: IKSolver, line: CartesianLine, q0: np.ndarray, searches: int = 4
) -> float:
    """The factor (>= 1) by which `line`'s duration must grow for the joints to follow it.

    Runs the IK along the line from the arm angles `q0` [rad] at the control rate, then seeds
    it back at `q0` (at rest). Velocity scales with 1/k, acceleration with 1/k^2. A reference
    that hits the IK's own velocity limit is distorted (its joints brake abruptly when it
    comes off the limit), so the first estimate is too high: the smallest feasible factor is
    then searched between 1 and it by bisection (`searches` more runs at most).
    """
    high = _excess(ik, line, q0, 1.0)
    if high <= _FEASIBLE:
        return 1.0
    low = 1.0
    for _ in range(searches):
        mid = 0.5 * (low + high)
        if _excess(ik, line, q0, mid) <= _FEASIBLE:
            high = mid
        else:
            low = mid
        if high - low < 0.05:
            break
    return high


_FEASIBLE = 1.08
"""Excess tolerated: the limiter absorbs it (its limits are already inside the robot's)."""


def _excess(ik: IKSolver, line: CartesianLine, q0: np.ndarray, k: float) -> float:
    """How far the IK's reference along `line` stretched by `k` exceeds the limits (>= 1)."""
    dt = STRIDE * ik.dt
    steps = max(2, math.ceil(line.duration * k / dt) + 1)
    ik.reset(q0)
    v = np.empty((steps, ik.n))
    for i in range(steps):
        pos, rot = line.sample_so3((i + 1) * dt / k)
        v[i] = ik.reference_step(pos, rot, dt)
    ik.reset(q0)
    acc = np.diff(v, axis=0, prepend=np.zeros((1, ik.n))) / dt
    k_v = float(np.max(np.abs(v) / (MARGIN * ik.limiter.v_max)))
    k_a = math.sqrt(float(np.max(np.abs(acc) / (MARGIN * ik.limiter.a_max))))
    return max(1.0, k_v, k_a)
