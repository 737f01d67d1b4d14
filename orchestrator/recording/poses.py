"""Body poses: static bodies once, moving bodies every control tick, sent as columns."""

from __future__ import annotations

import mujoco
import numpy as np
import rerun as rr

from .batches import StaticBatch, TemporalBatch, fixed_size_lists
from .geometry import body_names
from .paths import body_path
from .timeline import Rows

__all__ = ["BodyPoses"]

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

    def add_columns(self, batch: TemporalBatch, values: dict[str, np.ndarray]) -> None:
        """Add rows of the per-tick table to `batch`: a Transform3D per moving body."""
        # body-major float32 copies: each body's rows are then contiguous
        pos = np.ascontiguousarray(values["pos"][:, self.moving].transpose(1, 0, 2), np.float32)
        xyzw = values["quat"][:, self.moving][:, :, [1, 2, 3, 0]].transpose(1, 0, 2)
        xyzw = np.ascontiguousarray(xyzw, np.float32)
        for j, b in enumerate(self.moving):
            path = self.paths[int(b)]
            batch.add(path, _TRANSLATION, fixed_size_lists(pos[j]))
            batch.add(path, _QUATERNION, fixed_size_lists(xyzw[j]))


def _transform(pos: np.ndarray, quat_wxyz: np.ndarray) -> rr.Transform3D:
    w, x, y, z = (float(v) for v in quat_wxyz)
    return rr.Transform3D(
        translation=np.asarray(pos, dtype=np.float64), quaternion=rr.Quaternion(xyzw=[x, y, z, w])
    )
