"""Slow a Cartesian motion down, as a whole, until the joints can follow it.

A move's straight line with its jerk-limited timing says nothing about the joints: near the
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

from .blended_path import BlendedPath
from .ik import IKSolver
from .trajectory import CartesianLine

__all__ = ["feasible_time_scale", "fit_path_to_joints", "slow_where_exceeded"]

MARGIN = 0.95
"""Fraction of the limiter's limits the stretched reference may use."""

STRIDE = 3
"""Control ticks per step of a dry run: a 30 ms step resolves the velocity and acceleration
of a move (whose ramps last 0.1 s and more) at a third of the cost of running every tick."""


def feasible_time_scale(
    ik: IKSolver, line: CartesianLine | BlendedPath, q0: np.ndarray, searches: int = 4
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
        if _excess(ik, line, q0, mid, stop_above=_FEASIBLE) <= _FEASIBLE:
            high = mid
        else:
            low = mid
        if high - low < 0.05:
            break
    return high


_FEASIBLE = 1.08
"""Excess tolerated: the limiter absorbs it (its limits are already inside the robot's)."""


def _excess(
    ik: IKSolver,
    line: CartesianLine | BlendedPath,
    q0: np.ndarray,
    k: float,
    stop_above: float | None = None,
) -> float:
    """How far the IK's reference along `line` stretched by `k` exceeds the limits (>= 1).

    With `stop_above`, the dry run stops as soon as the excess is known to be above it (it
    returns the excess so far, which is): a bisection only asks which side of the bound a
    factor is on, and the samples up to that point decide it exactly as the whole run would
    (the checks are the same comparisons on the same numbers, `_CHECK_EVERY` rows at a time).
    """
    dt = STRIDE * ik.dt
    steps = max(2, math.ceil(line.duration * k / dt) + 1)
    ik.reset(q0)
    v = np.empty((steps, ik.n))
    v_lim = MARGIN * ik.limiter.v_max
    a_lim = MARGIN * ik.limiter.a_max
    k_v = k_a = 0.0
    checked = 0
    for i in range(steps):
        pos, rot = line.sample_so3((i + 1) * dt / k)
        v[i] = ik.reference_step(pos, rot, dt)
        if stop_above is not None and (i + 1 - checked >= _CHECK_EVERY or i + 1 == steps):
            rows = v[checked : i + 1]
            before = v[checked - 1 : checked] if checked > 0 else np.zeros((1, ik.n))
            acc = np.diff(rows, axis=0, prepend=before) / dt
            k_v = max(k_v, float(np.max(np.abs(rows) / v_lim)))
            k_a = max(k_a, math.sqrt(float(np.max(np.abs(acc) / a_lim))))
            checked = i + 1
            if max(1.0, k_v, k_a) > stop_above:
                ik.reset(q0)
                return max(1.0, k_v, k_a)
    ik.reset(q0)
    acc = np.diff(v, axis=0, prepend=np.zeros((1, ik.n))) / dt
    k_v = float(np.max(np.abs(v) / v_lim))
    k_a = math.sqrt(float(np.max(np.abs(acc) / a_lim)))
    return max(1.0, k_v, k_a)


_CHECK_EVERY = 8
"""Dry-run steps between the early-stop checks of `_excess` (each check costs numpy calls)."""


def fit_path_to_joints(ik: IKSolver, path: BlendedPath, q0: np.ndarray, passes: int = 2) -> None:
    """Retime `path` so that, point by point, the joints can follow it (a path is slowed
    only where a joint limits it, not as a whole).

    A dry run of the IK along the path gives each joint's rate of change along the path,
    dq/ds [rad/m]; where the path moves at ds/dt, joint j moves at dq_j/ds * ds/dt. So the
    path's speed is capped at min_j v_max_j / |dq_j/ds|, its acceleration along the path at
    min_j a_max_j / |dq_j/ds|, and its speed again where dq/ds changes fast (the centripetal
    term d2q/ds2 * (ds/dt)^2) at sqrt(a_max_j / |d2q_j/ds2|). Run twice: the first dry run
    may saturate the IK's velocity limit and understate dq/ds.
    """
    dt = STRIDE * ik.dt
    v_max = MARGIN * ik.limiter.v_max
    a_max = MARGIN * ik.limiter.a_max
    for _ in range(passes):
        s, v = _reference_along(ik, path, q0, dt)
        sdot = np.diff(s) / dt
        moving = sdot > 0.02  # dq/ds is noise where the path barely moves
        if np.count_nonzero(moving) < 3:
            return
        s_mid = 0.5 * (s[:-1] + s[1:])[moving]
        dq_ds = v[moving] / sdot[moving, None]
        d2q_ds2 = np.gradient(dq_ds, s_mid, axis=0) if len(s_mid) > 2 else np.zeros_like(dq_ds)
        slope = np.maximum(np.abs(dq_ds), 1e-9)
        v_cap = np.min(v_max / slope, axis=1)
        v_cap = np.minimum(
            v_cap, np.min(np.sqrt(a_max / np.maximum(np.abs(d2q_ds2), 1e-9)), axis=1)
        )
        a_cap = np.min(a_max / slope, axis=1)
        order = np.argsort(s_mid, kind="stable")
        path.limit_speed(s_mid[order], v_cap[order], a_cap[order])


def slow_where_exceeded(
    ik: IKSolver, path: BlendedPath, q0: np.ndarray, passes: int = 4, reach_m: float = 0.003
) -> float:
    """Slow `path` only where the IK's reference along it exceeds the limits, not as a whole;
    returns the factor by which its duration must still grow as a whole
    (`feasible_time_scale` of the path so slowed).

    `fit_path_to_joints` caps the path's speed and its acceleration along it separately, from
    the joints' rate of change along the path; a joint's acceleration is the sum of both terms
    (dq/ds * d2s/dt2 + d2q/ds2 * (ds/dt)^2) and of what the IK's own posture task adds, so the
    reference still exceeds the limits here and there (pick_place's approach by 1.5-1.7x in
    acceleration, on joint 2, over a tenth of its length). `feasible_time_scale` would then
    slow the whole motion, its guarded stretch and its straight runs too (by 1.15-1.25x).
    Here each pass runs the reference as `feasible_time_scale` measures it and, around every
    sample over the limits (`reach_m` [m] either side of it), lowers the speed cap by the
    velocity's excess and the acceleration cap by the acceleration's. Where that ends slower
    than slowing the path as a whole would (the excess moved rather than went), the path is
    timed as it came and slowed as a whole.
    """
    before = path.limits
    whole = path.duration * feasible_time_scale(ik, path, q0)
    dt = STRIDE * ik.dt
    v_lim = MARGIN * ik.limiter.v_max
    a_lim = MARGIN * ik.limiter.a_max
    for _ in range(passes):
        s, v = _reference_along(ik, path, q0, dt)
        acc = np.diff(v, axis=0, prepend=np.zeros((1, ik.n))) / dt
        # the excess over what `feasible_time_scale` tolerates (the limiter absorbs it)
        k_v = np.max(np.abs(v) / v_lim, axis=1) / _FEASIBLE
        k_a = np.max(np.abs(acc) / a_lim, axis=1) / _FEASIBLE**2
        if max(float(np.max(k_v)), float(np.max(k_a))) <= 1.0:
            break
        sdot = np.diff(s) / dt
        grid = path.arc_lengths
        v_cap = np.full(len(grid), np.inf)
        a_cap = np.full(len(grid), np.inf)
        for i in np.flatnonzero((k_v > 1.0) | (k_a > 1.0)):
            # the sample's span of the path, and the one before it (an acceleration is the
            # difference of two samples' velocities)
            span = (grid >= s[max(i - 1, 0)] - reach_m) & (grid <= s[i + 1] + reach_m)
            if k_v[i] > 1.0:
                v_cap[span] = np.minimum(v_cap[span], max(float(sdot[i]), 0.02) / k_v[i])
            if k_a[i] > 1.0:
                a_cap[span] = np.minimum(a_cap[span], path.accel_limits[span] / k_a[i])
        path.cap(v_cap, a_cap)
    stretch = feasible_time_scale(ik, path, q0)
    if path.duration * stretch <= whole:
        return stretch
    path.set_limits(before)
    return whole / path.duration


def _reference_along(
    ik: IKSolver, path: BlendedPath, q0: np.ndarray, dt: float
) -> tuple[np.ndarray, np.ndarray]:
    """The IK's reference run along `path` from `q0` every `dt` [s]: the path's progress at
    each sample (from 0, one more than the samples) and the reference's joint velocity over
    each [rad/s]. The IK is reset to `q0` before and after."""
    steps = max(3, math.ceil(path.duration / dt) + 1)
    ik.reset(q0)
    s = np.empty(steps + 1)
    s[0] = 0.0
    v = np.empty((steps, ik.n))
    for i in range(steps):
        t = (i + 1) * dt
        s[i + 1] = path.progress(t)
        pos, rot = path.sample_so3(t)
        v[i] = ik.reference_step(pos, rot, dt)
    ik.reset(q0)
    return s, v
