"""Body poses: static bodies once, moving bodies whenever they moved, sent as columns.

A body's pose is sent at the control ticks it moved: its position quantized to `POS_STEP_M`
and its rotation to `QUAT_STEP` changed since the tick before. A parcel resting in its bin,
a cube on the table, an arm holding still send nothing (Rerun shows the last pose sent): in
a sorting run most of the bodies rest most of the time. The error this leaves is under the
quantum (0.1 mm), far below what a viewer shows.
"""

from __future__ import annotations

import mujoco
import numpy as np
import rerun as rr
from rerun.chunk import Chunk

from .batches import StaticBatch, TemporalBatch, fixed_size_lists
from .geometry import body_names
from .paths import body_path
from .timeline import Rows

__all__ = ["POS_STEP_M", "QUAT_STEP", "BodyPoses"]

POS_STEP_M = 1e-4
"""A body whose position moves by less than this between ticks is at rest there [m]."""
QUAT_STEP = 1e-4
"""The same for each quaternion component (~0.01 deg)."""

_TRANSLATION = rr.Transform3D.descriptor_translation()
_QUATERNION = rr.Transform3D.descriptor_quaternion()


class BodyPoses:
    """Samples the world pose of bodies and sends them as Transform3D columns.

    Only bodies that carry something are logged: drawn geoms, or a frame (`anchor`). A body
    welded to the world (and not mocap) is static: its pose is logged once. Every other
    logged body gets one row per control tick on both timelines.

    Args:
        model: The compiled model.
        carriers: Ids of the bodies that carry drawn geoms.
    """

    def __init__(self, model: mujoco.MjModel, carriers: frozenset[int]) -> None:
        self.model = model
        names = body_names(model)
        self.logged = set(carriers) | {0}
        moving = [
            b
            for b in range(1, model.nbody)
            if int(model.body_weldid[b]) != 0 or int(model.body_mocapid[b]) >= 0
        ]
        self._moving = set(moving)
        self.moving = np.asarray([b for b in moving if b in self.logged], dtype=np.int64)
        self.paths = {b: body_path(names[b]) for b in range(model.nbody)}
        self.fields = {"pos": (model.nbody, 3), "quat": (model.nbody, 4)}
        """Fields of the per-tick table: every body's position [m] and quaternion (w, x, y,
        z). Whole-array copies are the cheapest per tick; moving bodies are picked when sent."""

    def anchor(self, body: int) -> int:
        """The logged body a frame on `body` should hang from: `body` itself, or its nearest
        ancestor in the same rigid (welded) group that is logged. A body without one is
        added to the logged bodies."""
        m = self.model
        b = body
        while b not in self.logged and b > 0 and m.body_weldid[b] == m.body_weldid[body]:
            b = int(m.body_parentid[b])
        if b in self.logged and m.body_weldid[b] == m.body_weldid[body]:
            return b
        self.logged.add(body)
        if body in self._moving:
            self.moving = np.sort(np.append(self.moving, body))
        return body

    def log_static(self, static: StaticBatch, data: mujoco.MjData) -> None:
        """Log the pose of every logged static body (world frame) as static data."""
        for b in sorted(self.logged):
            if b not in self._moving:
                static.log(self.paths[b], _transform(data.xpos[b], data.xquat[b]))

    def sample(self, rows: Rows, i: int, data: mujoco.MjData) -> None:
        """Fill row `i` of the per-tick table with the body poses."""
        rows.pos[i] = data.xpos
        rows.quat[i] = data.xquat

    def chunks(
        self, ticks: np.ndarray, t_s: np.ndarray, values: dict[str, np.ndarray]
    ) -> list[Chunk]:
        """Rows of the per-tick table as one Transform3D chunk per moving body, holding the
        rows at which it moved (`POS_STEP_M`, `QUAT_STEP`); the first row a body ever sends
        is always kept."""
        pos = values["pos"][:, self.moving]  # (n, bodies, 3)
        quat = values["quat"][:, self.moving]
        key = np.concatenate([np.rint(pos / POS_STEP_M), np.rint(quat / QUAT_STEP)], axis=2)
        prev = np.concatenate([self._last_key(len(self.moving), key), key[:-1]], axis=0)
        moved = (key != prev).any(axis=2)  # (n, bodies)
        self._last = dict(zip(self.moving.tolist(), key[-1], strict=True)) if len(key) else {}
        # bodies that moved at the same rows (the links of a moving arm) share one batch
        groups: dict[bytes, list[int]] = {}
        for j in range(len(self.moving)):
            if moved[:, j].any():
                groups.setdefault(moved[:, j].tobytes(), []).append(j)
        out = []
        for members in groups.values():
            rows = np.flatnonzero(moved[:, members[0]])
            batch = TemporalBatch(ticks[rows], t_s[rows])
            for j in members:
                path = self.paths[int(self.moving[j])]
                batch.add(path, _TRANSLATION, fixed_size_lists(pos[rows, j]))
                batch.add(path, _QUATERNION, fixed_size_lists(quat[rows, j][:, [1, 2, 3, 0]]))
            out += batch.chunks()
        return out

    def _last_key(self, n: int, key: np.ndarray) -> np.ndarray:
        """The quantized pose each moving body last sent (NaN: never: it is sent). Shape
        (1, n, 7)."""
        last = getattr(self, "_last", {})
        out = np.full((1, n, key.shape[2]), np.nan)
        for j, b in enumerate(self.moving.tolist()):
            if b in last:
                out[0, j] = last[b]
        return out


def _transform(pos: np.ndarray, quat_wxyz: np.ndarray) -> rr.Transform3D:
    w, x, y, z = (float(v) for v in quat_wxyz)
    return rr.Transform3D(
        translation=np.asarray(pos, dtype=np.float64), quaternion=rr.Quaternion(xyzw=[x, y, z, w])
    )
