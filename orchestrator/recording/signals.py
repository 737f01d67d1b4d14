"""Scalar signals of the robot and of every active guard, sampled each control tick."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import rerun as rr
from rerun.chunk import Chunk

from .batches import StaticBatch, TemporalBatch, scalar_lists
from .paths import GUARDS, SIGNALS, part

if TYPE_CHECKING:
    from collections.abc import Callable

    from ..engine.context import Context
    from ..guards.base import Guard
    from .timeline import Rows

__all__ = [
    "GRIPPER_WIDTH",
    "GuardSignals",
    "JOINT_TORQUE",
    "RobotSignals",
    "TCP_ERROR",
    "WRIST_FORCE",
]

TCP_ERROR = f"{SIGNALS}/tcp_error_m"
"""|TCP - IK target| [m], only while a motion skill has a target."""
WRIST_FORCE = f"{SIGNALS}/wrist_force_n"
"""External force on the hand [N]: x, y, z (world frame) and the norm."""
JOINT_TORQUE = f"{SIGNALS}/joint_torque_nm"
"""Commanded arm joint torques [N m], one series per joint."""
GRIPPER_WIDTH = f"{SIGNALS}/gripper_width_m"
"""Distance between the fingers [m]."""

_FORCE_NAMES = ("x", "y", "z", "norm")
_FORCE_COLORS = (0xE15759FF, 0x59A14FFF, 0x4E79A7FF, 0x333333FF)
_VALUE_COLOR, _LIMIT_COLOR = 0x4E79A7FF, 0xD62728FF
_SCALARS = rr.Scalars.descriptor_scalars()


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
        self.fields = {"force": (3,), "tau": (n_tau,), "grip": (), "tcp": (3,), "target": ()}
        """Fields of the per-tick table: wrist force [N] (world), torques [N m], gripper
        width [m], TCP position [m] and the index of the IK target in `targets` (-1: none)."""
        self.targets: list[np.ndarray] = []
        """Position [m] of every IK target seen, in order."""
        self._target: object = None

    def log_static(self, static: StaticBatch) -> None:
        """Series names and colours."""
        static.log(
            WRIST_FORCE,
            rr.SeriesLines(names=list(_FORCE_NAMES), colors=np.array(_FORCE_COLORS, np.uint32)),
        )
        static.log(JOINT_TORQUE, rr.SeriesLines(names=self.joint_names))
        static.log(TCP_ERROR, rr.SeriesLines(names=["|tcp - target| [m]"]))
        static.log(GRIPPER_WIDTH, rr.SeriesLines(names=["gripper width [m]"]))

    def sample(self, rows: Rows, i: int, ctx: Context) -> None:
        """Fill row `i` of the per-tick table with the signals."""
        rows.force[i] = ctx.wrist_force()
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
        batch.add(WRIST_FORCE, _SCALARS, scalar_lists(np.hstack([force, norm])))
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


class GuardSignals:
    """Each active guard's monitored value next to its limit, at `guards/<name>`.

    Guards are told apart by name; a second active guard of the same name (a state-level
    guard next to a machine-level one) is `<name>_2`.
    """

    def __init__(self) -> None:
        self._rows: dict[str, list[tuple[int, float, float, float]]] = {}
        """Guard key -> (tick, t [s], value, limit) rows."""
        self._styled: set[str] = set()
        self._active: tuple[Guard, ...] = ()
        self._calls: list[tuple[Callable, Callable]] = []
        """(guard.monitored, rows.append) of each active guard."""

    def sample(self, tick: int, t_s: float, ctx: Context, guards: list[Guard]) -> None:
        """Record `guard.monitored(ctx)` of every guard in `guards` that has a scalar."""
        if tuple(guards) != self._active:
            self._plan(guards)
        for monitored, append in self._calls:
            watched = monitored(ctx)
            if watched is not None:
                append((tick, t_s, watched[0], watched[1]))

    def _plan(self, guards: list[Guard]) -> None:
        """Key and buffer of each guard in a new set of active guards."""
        self._active = tuple(guards)
        seen: dict[str, int] = {}
        self._calls = []
        for guard in guards:
            count = seen.get(guard.name, 0) + 1
            seen[guard.name] = count
            key = guard.name if count == 1 else f"{guard.name}_{count}"
            self._calls.append((guard.monitored, self._rows.setdefault(key, []).append))

    def chunks(self) -> list[Chunk]:
        """The buffered rows (two series per guard: value and limit) as chunks; the buffer is
        emptied. Guards sampled at the same ticks (the usual case) share one batch."""
        static = StaticBatch()
        batches: dict[bytes, TemporalBatch] = {}
        for key, rows in self._rows.items():
            if not rows:
                continue
            entity = f"{GUARDS}/{part(key)}"
            if key not in self._styled:
                static.log(
                    entity,
                    rr.SeriesLines(
                        names=[f"{key} value", f"{key} limit"],
                        colors=np.array([_VALUE_COLOR, _LIMIT_COLOR], np.uint32),
                    ),
                )
                self._styled.add(key)
            table = np.array(rows, dtype=np.float64)
            ticks = table[:, 0].astype(np.int64)
            batch = batches.get(ticks.tobytes())
            if batch is None:
                batch = batches[ticks.tobytes()] = TemporalBatch(ticks, table[:, 1])
            batch.add(entity, _SCALARS, scalar_lists(table[:, 2:]))
            rows.clear()
        out = static.chunks()
        for batch in batches.values():
            out += batch.chunks()
        return out
