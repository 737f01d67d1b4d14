"""Geoms a run reshapes: drawn on the timeline, drawn again whenever they change.

A conveyor shift recycles a fixed pool of parcel bodies: each time a body is fed again it gets
a new box size and the colour of its new class (world/conveyor.py). The static geometry is
drawn once, and Rerun lets static data win over data on a timeline, so the shape of such a
geom is logged on the timeline instead: at the first control tick, and at every tick its size
or colour differs from what was last drawn.
"""

from __future__ import annotations

from collections.abc import Sequence

import mujoco
import numpy as np
from rerun.chunk import Chunk

from .geometry import GeomVisual, geom_archetype
from .timeline import time_columns

__all__ = ["ReshapedGeoms"]


class ReshapedGeoms:
    """Watches the size and colour of the geoms a run may change and logs their shapes.

    Args:
        model: The compiled model (the run changes its `geom_size` / `geom_rgba`).
        visuals: The geoms to watch (`StaticGeometry.reshaped`).
    """

    def __init__(self, model: mujoco.MjModel, visuals: Sequence[GeomVisual]) -> None:
        self.model = model
        self.visuals = list(visuals)
        self._ids = np.array([v.geom_id for v in self.visuals], dtype=np.int64)
        self._drawn: tuple[np.ndarray, np.ndarray] | None = None
        """Sizes and colours last drawn (None: nothing drawn yet)."""
        self._chunks: list[Chunk] = []

    def sample(self, tick: int, t_s: float) -> None:
        """Draw every watched geom whose size or colour changed since it was last drawn (all
        of them on the first call). Costs two small array compares when nothing changed."""
        if not self.visuals:
            return
        size, rgba = self.model.geom_size[self._ids], self.model.geom_rgba[self._ids]
        drawn = self._drawn
        if drawn is not None and np.array_equal(size, drawn[0]) and np.array_equal(rgba, drawn[1]):
            return
        for k, visual in enumerate(self.visuals):
            if drawn is not None and (
                np.array_equal(size[k], drawn[0][k]) and np.array_equal(rgba[k], drawn[1][k])
            ):
                continue
            shape = geom_archetype(self.model, visual.geom_id)
            if shape is None:
                continue
            columns = [
                batch.partition([len(batch.as_arrow_array())])
                for batch in shape.as_component_batches()
            ]
            self._chunks.append(
                Chunk.from_columns(
                    visual.entity,
                    indexes=time_columns(np.array([tick]), np.array([t_s])),
                    columns=columns,
                )
            )
        self._drawn = (size, rgba)

    def chunks(self) -> list[Chunk]:
        """The shapes drawn since the last call."""
        out, self._chunks = self._chunks, []
        return out
