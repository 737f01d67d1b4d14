"""A motion's dry run: the IK along its whole path, before anything moves.

The IK integrates its own joint reference open loop (skills/ik.py), so the reference a motion
will command is known at its start: running the IK along the path, tick by tick from the
measured joints, gives exactly the joint path the ticks will follow on the path, and where it
ends — at the target, or stuck short of it (a joint limit, the edge of the reach, an
orientation the wrist cannot take). A move commits only to a target its dry run reaches; a
target it does not is `unreachable` at once, with the residual, instead of an arm that strains
for seconds towards a pose it cannot take (a parcel 0.84 m out, hand down: 9.8 s of joint
accelerations up to 1.76x the datasheet and 100 % torque before a guard stopped it).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Protocol

import numpy as np

from .ik import IKSolver

if TYPE_CHECKING:
    import mink
    import mujoco

__all__ = ["DryRun", "dry_run", "path_time"]

_STALL_TICKS = 10
"""Ticks with the reference at rest short of the target that count as stuck."""
_STALL_RAD_S = 1e-3
"""Joint speed of the reference below which it is at rest [rad/s]."""


class Path(Protocol):
    """A timed Cartesian path (`CartesianLine`, `BlendedPath`)."""

    duration: float

    def sample_so3(self, t: float) -> tuple[np.ndarray, mink.SO3]: ...


@dataclass(frozen=True)
class DryRun:
    """The IK's reference along a motion, tick by tick.

    Attributes:
        q_path: The reference's joint angles at the end of each control tick [rad], shape
            (ticks, n): the path's ticks, then the ticks it took to converge at its end.
        velocity: The reference's joint velocity over each of the path's ticks [rad/s],
            shape (path_ticks, n): with `q_path`, what a move's ticks on the path replay
            (`IKSolver.follow`) instead of solving the IK again.
        dt: Control period [s].
        path_ticks: Ticks on the path (the rest converge at its end).
        residual_m: Distance of the reference's TCP from the target at the end [m].
        residual_rad: Its orientation error there [rad].
        reached: The reference converged within half the motion's tolerances.
        lag_rad: Largest lag of the limited joint command behind the reference on the path
            [rad] (the joint limiter at the robot's velocity, acceleration and jerk limits:
            a command that lags, lags joint by joint and leaves the Cartesian path).
        torque_ratio: Largest torque the limited command asks of a joint on the path, as a
            fraction of its limit (inverse dynamics of the robot's model, no payload), and
            the joint (0-based). The command, not the reference: near the edge of the reach
            the IK's reference can chatter tick to tick (+-60 rad/s^2 on joint 2), which the
            limiter smooths and the arm never sees.
    """

    q_path: np.ndarray
    velocity: np.ndarray
    dt: float
    path_ticks: int
    residual_m: float
    residual_rad: float
    reached: bool
    lag_rad: float
    torque_ratio: tuple[float, int] = (0.0, 0)
    sigma_min: float = float("inf")


def dry_run(
    ik: IKSolver,
    path: Path,
    stretch: float,
    q0: np.ndarray,
    settle_s: float,
    tolerance_m: float,
    tolerance_rad: float,
    command: tuple[np.ndarray, np.ndarray] | None = None,
    effort_limit: np.ndarray | None = None,
) -> DryRun:
    """Run the IK along `path` (its time stretched by `stretch`) from the arm angles `q0`
    [rad] at the control rate, then hold its end for up to `settle_s` [s] until the reference
    is within half of `tolerance_m` [m] and `tolerance_rad` [rad] of it (what a move's
    ticks need to call it reached), or stuck short of it. The joint limiter follows the
    reference as it does on the ticks, from `command` (the controller's setpoint: angles
    [rad], velocities [rad/s]; default `q0` at rest). The solver is seeded back at `q0` (at
    rest) afterwards, so the ticks that follow start where the dry run started.
    """
    dt = ik.dt
    path_ticks = max(1, math.ceil(path.duration * stretch / dt - 1e-9))
    settle_ticks = max(1, math.ceil(settle_s / dt))
    ik.reset(q0)
    if command is not None:
        ik.restart_from(*command)
    limiter = ik.limiter
    n = ik.n
    qpos = ik.config.data.qpos  # the IK's reference (`ik.q` is a copy of it)
    rows = np.empty((path_ticks + settle_ticks, n))
    commands = np.empty((path_ticks, n))
    velocity = np.empty((path_ticks, n))
    end_pos, end_rot = path.sample_so3(path.duration)
    pos_tol, rot_tol = 0.5 * tolerance_m, 0.5 * tolerance_rad
    err_pos = err_rot = math.inf
    still = 0
    count = 0
    q_ref = qpos[:n].copy()  # the reference where the tick starts: q0, then the last row
    for i in range(path_ticks + settle_ticks):
        if i < path_ticks:
            pos, rot = path.sample_so3(path_time(i, dt, stretch, path.duration))
        else:
            pos, rot = end_pos, end_rot
        v = ik.reference_step(pos, rot, dt)
        rows[i] = qpos[:n]
        count = i + 1
        if i < path_ticks:
            velocity[i] = v
            limiter.step(q_ref, v)  # what `IKSolver.step` hands the controller
            commands[i] = limiter.position
        q_ref = rows[i]
        if i + 1 < path_ticks:
            continue
        err = ik.error
        err_pos = float(np.linalg.norm(err[:3]))
        err_rot = float(np.linalg.norm(err[3:]))
        if err_pos <= pos_tol and err_rot <= rot_tol:
            break
        still = still + 1 if float(np.max(np.abs(v))) < _STALL_RAD_S else 0
        if still >= _STALL_TICKS:
            break  # stuck short of the target: a joint limit, the edge of the reach
    ik.reset(q0)
    q_path = rows[:count].copy()
    on_path = min(count, path_ticks)
    # the largest lag of the command behind the reference over the path's ticks (what
    # `ik.lag` reads after each of them), in one pass
    lag = float(np.max(np.abs(rows[:on_path] - commands[:on_path])))
    torque = (
        (0.0, 0)
        if effort_limit is None
        else _torque_ratio(ik, commands[:on_path], q0, dt, effort_limit)
    )
    return DryRun(
        q_path=q_path,
        velocity=velocity,
        dt=dt,
        path_ticks=path_ticks,
        residual_m=err_pos,
        residual_rad=err_rot,
        reached=err_pos <= pos_tol and err_rot <= rot_tol,
        lag_rad=lag,
        torque_ratio=torque,
        sigma_min=_sigma_min(ik, q_path[-1]),
    )


def path_time(tick: int, dt: float, stretch: float, duration: float) -> float:
    """Where on a path of `duration` [s], stretched in time by `stretch`, the control tick
    `tick` (0: the first after the motion's start) of `dt` [s] samples it [s]: at the end of
    the tick, on the grid of whole ticks (a move's ticks on the path sample the same times,
    not the simulated clock, whose sum of physics steps drifts from it by ~1e-14 s)."""
    return min((tick + 1) * dt / stretch, duration)


_INVERSE: dict[int, mujoco.MjData] = {}
"""An MjData per robot model for the dry runs' inverse dynamics (never the IK's own)."""


def _data(ik: IKSolver) -> mujoco.MjData:
    import mujoco

    model = ik.config.model
    data = _INVERSE.get(id(model))
    if data is None:
        data = _INVERSE[id(model)] = mujoco.MjData(model)
    return data


def _sigma_min(ik: IKSolver, q: np.ndarray) -> float:
    """The smallest singular value of the TCP's 6-D Jacobian over the IK's joints at `q`."""
    import mujoco

    model, data = ik.config.model, _data(ik)
    data.qpos[: ik.n] = q[: ik.n]
    mujoco.mj_kinematics(model, data)
    mujoco.mj_comPos(model, data)
    jac = np.zeros((6, model.nv))
    mujoco.mj_jacSite(model, data, jac[:3], jac[3:], model.site(ik.robot.tcp_site).id)
    return float(np.linalg.svd(jac[:, : ik.n], compute_uv=False)[-1])


def _torque_ratio(
    ik: IKSolver, q_path: np.ndarray, q0: np.ndarray, dt: float, limit: np.ndarray
) -> tuple[float, int]:
    """The largest |torque| / limit a joint needs along the joint path `q_path` (the command
    at the end of each tick of `dt` [s], from `q0`), by inverse dynamics (`mj_inverse`) of the
    IK's robot model, and which joint: gravity and the path's own accelerations, no
    payload."""
    import mujoco

    model, data = ik.config.model, _data(ik)
    n = ik.n
    q = np.vstack([q0[None, :n], q_path[:, :n]])
    qd = np.gradient(q, dt, axis=0)
    qdd = np.gradient(qd, dt, axis=0)
    torque = np.empty((len(q) - 1, n))
    for i in range(1, len(q)):
        data.qpos[:n], data.qvel[:n], data.qacc[:n] = q[i], qd[i], qdd[i]
        mujoco.mj_inverse(model, data)
        torque[i - 1] = data.qfrc_inverse[:n]
    # the first largest ratio, row by row (the earliest tick, then the lowest joint)
    ratio = np.abs(torque) / limit
    at = int(np.argmax(ratio))
    best = float(ratio.flat[at])
    return (best, at % n) if best > 0.0 else (0.0, 0)
