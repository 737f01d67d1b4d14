"""Targets as frames: the IK goal over time, the scene's markers and the TCP."""

from __future__ import annotations

from typing import TYPE_CHECKING

import mujoco
import numpy as np
import rerun as rr
from rerun.chunk import Chunk

from .framing import VIEW_DIR
from .geometry import body_names
from .paths import TARGETS, body_path, part
from .timeline import time_columns

if TYPE_CHECKING:
    from ..engine.context import Context
    from .batches import StaticBatch
    from .poses import BodyPoses

__all__ = ["IK_TARGET", "Targets", "label_raises"]

IK_TARGET = f"{TARGETS}/ik_target"
"""The pose the active motion skill drives the TCP to; its axes vanish while there is none."""
_AXIS_M = 0.08
"""Axis length of target frames [m]."""
_MARKER_AXIS_M = 0.05
_LABEL_STEP_M = 0.09
"""Markers closer than `_CROWD_M` to each other have their names raised this much apart, the
one farthest from the 3D view's eye highest: seen from the eye (framing.py), a row of bins
piled their names on one another."""
_CROWD_M = 0.3


def label_raises(markers: dict[str, np.ndarray]) -> dict[str, float]:
    """How far above each marker its name is written [m]: 0 for a marker alone; in a group
    of markers each within `_CROWD_M` of another, `_LABEL_STEP_M` more for each one nearer the
    eye than it."""
    toward_eye = VIEW_DIR / np.linalg.norm(VIEW_DIR)
    names = list(markers)
    group = {n: n for n in names}

    def root(n: str) -> str:
        while group[n] != n:
            n = group[n]
        return n

    for i, a in enumerate(names):
        for b in names[i + 1 :]:
            if np.linalg.norm(np.asarray(markers[a]) - np.asarray(markers[b])) < _CROWD_M:
                group[root(b)] = root(a)
    near = {n: float(np.asarray(markers[n]) @ toward_eye) for n in names}
    return {
        n: _LABEL_STEP_M * sum(1 for m in names if root(m) == root(n) and near[m] > near[n])
        for n in names
    }


def _xyzw(quat_wxyz: np.ndarray | list[float]) -> list[float]:
    w, x, y, z = (float(v) for v in quat_wxyz)
    return [x, y, z, w]


class Targets:
    """Static frames for markers and the TCP; the IK target logged whenever it changes."""

    def __init__(self) -> None:
        self._last: object = ()
        self._rows: list[tuple[int, float, list[float] | None, list[float] | None]] = []

    def log_static(self, static: StaticBatch, ctx: Context, poses: BodyPoses) -> None:
        """Markers (`world/targets/<name>`: a labelled frame; their footprint is a model geom,
        logged with the world) and the TCP frame, hung from the logged body it is rigidly
        attached to (`<body>/tcp`)."""
        raises = label_raises(dict(ctx.world.markers))
        for name, pos in ctx.world.markers.items():
            entity = f"{TARGETS}/{part(name)}"
            static.log(
                entity,
                rr.Transform3D(translation=np.asarray(pos, dtype=np.float64)),
                rr.TransformAxes3D(_MARKER_AXIS_M),
                rr.Points3D([[0.0, 0.0, raises[name]]], labels=[name], radii=[0.002]),
            )
        m, d = ctx.model, ctx.data
        site = ctx.world.tcp_site
        body = poses.anchor(int(m.site_bodyid[site]))
        rot_body = d.xmat[body].reshape(3, 3)
        offset = rot_body.T @ (d.site_xpos[site] - d.xpos[body])
        quat = np.zeros(4)
        mujoco.mju_mat2Quat(quat, (rot_body.T @ d.site_xmat[site].reshape(3, 3)).ravel())
        static.log(
            f"{body_path(body_names(m)[body])}/tcp",
            rr.Transform3D(translation=offset, quaternion=rr.Quaternion(xyzw=_xyzw(quat))),
            rr.TransformAxes3D(_AXIS_M * 0.75),
        )

    def sample(self, tick: int, t_s: float, ctx: Context) -> None:
        """Record the IK target if it changed since the last control tick."""
        target = ctx.ik_target
        if target is self._last:
            return
        self._last = target
        if target is None:
            self._rows.append((tick, t_s, None, None))
        else:
            self._rows.append((tick, t_s, list(target.pos), _xyzw(target.quat)))

    def chunks(self) -> list[Chunk]:
        """The buffered target changes: pose rows, and axis lengths (0 when no target)."""
        if not self._rows:
            return []
        ticks = np.array([r[0] for r in self._rows])
        t_s = np.array([r[1] for r in self._rows])
        axes = np.array([_AXIS_M if r[2] is not None else 0.0 for r in self._rows])
        out = [
            Chunk.from_columns(
                IK_TARGET,
                indexes=time_columns(ticks, t_s),
                columns=rr.TransformAxes3D.columns(axis_length=axes),
            )
        ]
        posed = [i for i, r in enumerate(self._rows) if r[2] is not None]
        if posed:
            out.append(
                Chunk.from_columns(
                    IK_TARGET,
                    indexes=time_columns(ticks[posed], t_s[posed]),
                    columns=rr.Transform3D.columns(
                        translation=np.array([self._rows[i][2] for i in posed]),
                        quaternion=np.array([self._rows[i][3] for i in posed]),
                    ),
                )
            )
        self._rows = []
        return out
