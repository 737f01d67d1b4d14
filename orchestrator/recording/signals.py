"""Scalar signals of the robot and of every active guard, sampled each control tick."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
import rerun as rr

from .batches import StaticBatch, TemporalBatch, scalar_lists
from .paths import SIGNALS

if TYPE_CHECKING:
    from ..engine.context import Context
    from .timeline import Rows

__all__ = [
    "GRIPPER_WIDTH",
    "JOINT_TORQUE",
    "KEEP_EXTREMES",
    "KEEP_PEAK",
    "RobotSignals",
    "TCP_ERROR",
    "WRIST_FORCE",
    "WRIST_FORCE_XYZ",
]

TCP_ERROR = f"{SIGNALS}/tcp_error_m"
"""|TCP - IK target| [m], only while a motion skill has a target."""
WRIST_FORCE = f"{SIGNALS}/wrist_force_n"
"""External force on the hand [N], true (the noise-free sensor with the hand's true weight
removed): its norm at each control tick, and its peak over the tick's physics steps. What the
guards see (the sensed force, noise and faults included) is on their margins."""
WRIST_FORCE_XYZ = f"{SIGNALS}/wrist_force_xyz_n"
"""True external force on the hand [N]: x, y, z (world frame) per control tick."""
JOINT_TORQUE = f"{SIGNALS}/joint_torque_nm"
"""Commanded arm joint torques [N m], one series per joint."""
GRIPPER_WIDTH = f"{SIGNALS}/gripper_width_m"
"""Distance between the fingers [m]."""

_FORCE_NAMES = ("|F| per tick", "peak |F| over the tick's steps")
_FORCE_COLORS = (0x333333FF, 0xF28E2BFF)
_XYZ_NAMES = ("x", "y", "z")
_XYZ_COLORS = (0xE15759FF, 0x59A14FFF, 0x4E79A7FF)
_SCALARS = rr.Scalars.descriptor_scalars()
KEEP_EXTREMES = rr.components.AggregationPolicy.MinMax
"""How the viewer draws a signed series when several samples fall on one pixel column: their
least and largest value (a band), never their average (Rerun's default). A run longer than the
plot is wide has many ticks per pixel; averaged, a one-tick 10.5 N force peak is drawn at ~6 N."""
KEEP_PEAK = rr.components.AggregationPolicy.Max
"""The same for the wrist force's norm, where only the peak matters: the largest value per
pixel column, a single line (MinMax draws a zig-zag band)."""


class RobotSignals:
    """TCP error, wrist force, joint torques and gripper width, one row per control tick.

    Per tick only raw values are copied; norms and the TCP error are computed per batch
    when sending.

    Args:
        ctx: The episode context (read for sizes and joint names only).
    """

    def __init__(self, ctx: Context) -> None:
        n_tau = len(ctx.controller.tau)
        joints = list(getattr(ctx.robot, "arm_joints", ()))
        if len(joints) != n_tau:
            joints = [f"joint{i + 1}" for i in range(n_tau)]
        self.joint_names = joints
        self.fields = {
            "force": (3,), "peak": (), "tau": (n_tau,), "grip": (), "tcp": (3,), "target": (),
        }  # fmt: skip
        """Fields of the per-tick table: wrist force [N] (world), the peak true force norm
        since the last row [N], torques [N m], gripper width [m], TCP position [m] and the
        index of the IK target in `targets` (-1: none)."""
        self._true_sq = ctx.cell.wrist.true_norm_sq
        self.targets: list[np.ndarray] = []
        """Position [m] of every IK target seen, in order."""
        self._target: object = None

    def log_static(self, static: StaticBatch) -> None:
        """Series names and colours."""
        static.log(
            WRIST_FORCE,
            rr.SeriesLines(
                names=list(_FORCE_NAMES),
                colors=np.array(_FORCE_COLORS, np.uint32),
                aggregation_policy=KEEP_PEAK,
            ),
        )
        static.log(
            WRIST_FORCE_XYZ,
            rr.SeriesLines(
                names=list(_XYZ_NAMES),
                colors=np.array(_XYZ_COLORS, np.uint32),
                aggregation_policy=KEEP_EXTREMES,
            ),
        )
        for entity, names in (
            (JOINT_TORQUE, self.joint_names),
            (TCP_ERROR, ["|tcp - target| [m]"]),
            (GRIPPER_WIDTH, ["gripper width [m]"]),
        ):
            static.log(entity, rr.SeriesLines(names=names, aggregation_policy=KEEP_EXTREMES))

    def sample(self, rows: Rows, i: int, ctx: Context, peak_sq: float = -1.0) -> None:
        """Fill row `i` of the per-tick table with the signals. `peak_sq`: the largest true
        |F|^2 [N^2] over the physics steps since the last row (the recorder's `on_step`
        keeps it: ground truth, noise free, so reading it changes nothing the run sees);
        -1: none, the true force now."""
        rows.peak[i] = math.sqrt(peak_sq if peak_sq >= 0.0 else self._true_sq())
        # the true force (noise-free sensor, true hand weight removed): a pure read. Reading
        # the sensed force at an instant no guard reads it would draw the sensor's noise one
        # more time and change the run (surgical_complication's abort force did change)
        rows.force[i] = ctx.cell.wrist.true_force()
        rows.tau[i] = ctx.controller.tau
        rows.grip[i] = ctx.gripper_width
        rows.tcp[i] = ctx.tcp_pos
        target = ctx.ik_target
        if target is not self._target:
            self._target = target
            if target is not None:
                self.targets.append(np.asarray(target.pos, dtype=np.float64))
        rows.target[i] = -1 if target is None else len(self.targets) - 1

    def add_columns(
        self, batch: TemporalBatch, v: dict[str, np.ndarray], t_s: np.ndarray, ticks: np.ndarray
    ) -> TemporalBatch | None:
        """Add rows of the per-tick table to `batch`; return the TCP error, which only has the
        rows where a target existed, as a batch of its own (None if there was no target)."""
        force = v["force"]
        norm = np.linalg.norm(force, axis=1, keepdims=True)
        peak = v["peak"][:, None]
        batch.add(WRIST_FORCE, _SCALARS, scalar_lists(np.hstack([norm, peak])))
        batch.add(WRIST_FORCE_XYZ, _SCALARS, scalar_lists(force))
        batch.add(JOINT_TORQUE, _SCALARS, scalar_lists(v["tau"]))
        batch.add(GRIPPER_WIDTH, _SCALARS, scalar_lists(v["grip"]))
        target = v["target"].astype(np.int64)
        has = target >= 0
        if not has.any():
            return None
        goal = np.asarray(self.targets)[target[has]]
        error = TemporalBatch(ticks[has], t_s[has])
        error.add(TCP_ERROR, _SCALARS, scalar_lists(np.linalg.norm(v["tcp"][has] - goal, axis=1)))
        return error
