"""The static geometry of a model as ready-to-send chunks, cached per model content.

Episodes of one scenario compile to models with identical geometry (only initial poses
differ), so a batch worker builds the chunks once and sends them in one call per episode.
"""

from __future__ import annotations

import hashlib
from collections import OrderedDict
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np
from rerun.chunk import Chunk

from .geometry import GeomVisual, model_geometry

__all__ = ["StaticGeometry", "geometry_chunks", "model_signature", "static_chunk"]

_FIELDS = (
    "geom_type", "geom_size", "geom_rgba", "geom_matid", "geom_group", "geom_bodyid",
    "geom_dataid", "geom_pos", "geom_quat", "mat_rgba", "mesh_vertadr", "mesh_vertnum",
    "mesh_faceadr", "mesh_facenum", "mesh_normaladr", "mesh_normalnum", "mesh_vert",
    "mesh_face", "mesh_normal", "mesh_facenormal", "hfield_size", "hfield_nrow",
    "hfield_ncol", "hfield_adr", "hfield_data", "name_bodyadr", "name_geomadr", "names",
    "body_parentid", "body_weldid", "body_mocapid", "body_jntnum", "site_pos", "site_quat",
    "site_bodyid", "name_siteadr",
)  # fmt: skip
"""Everything the static scene is built from (geometry, frames on bodies, and `body_pos` /
`body_quat` of bodies without joints, which fix static poses and welded offsets): equal
arrays mean an equal static scene. The initial pose of a free object (a per-seed cube
position) is not part of it."""
_CACHE_SIZE = 8


@dataclass(frozen=True)
class StaticGeometry:
    """The drawn part of a model.

    Attributes:
        chunks: One static chunk per drawable visible geom (shape + pose in its body; only
            the pose for a geom in `reshaped`).
        bodies: Ids of the bodies that carry at least one of them.
        skipped: Ids of visible geoms that cannot be drawn (SDF geoms without a mesh).
        reshaped: The drawable geoms the run may reshape or recolour: their shape is logged
            on the timeline (`recording/reshaped.py`), since static data would hide it.
    """

    chunks: list[Chunk]
    bodies: frozenset[int]
    skipped: list[int]
    reshaped: tuple[GeomVisual, ...] = ()


_cache: OrderedDict[str, StaticGeometry] = OrderedDict()


def model_signature(model: mujoco.MjModel) -> str:
    """A digest of the model arrays the static scene is built from (see `_FIELDS`)."""
    h = hashlib.blake2b(digest_size=16)
    for name in _FIELDS:
        h.update(np.ascontiguousarray(getattr(model, name)).tobytes())
    jointless = model.body_jntnum == 0
    h.update(np.ascontiguousarray(model.body_pos[jointless]).tobytes())
    h.update(np.ascontiguousarray(model.body_quat[jointless]).tobytes())
    h.update(np.float64(model.stat.extent).tobytes())
    return h.hexdigest()


def static_chunk(entity: str, *archetypes: Any) -> Chunk:
    """One static chunk holding all components of `archetypes` at `entity`."""
    columns = []
    for archetype in archetypes:
        for batch in archetype.as_component_batches():
            columns.append(batch.partition([len(batch.as_arrow_array())]))
    return Chunk.from_columns(entity, indexes=[], columns=columns)


def geometry_chunks(
    model: mujoco.MjModel, reshaped: frozenset[int] = frozenset()
) -> StaticGeometry:
    """The static geometry of `model`, cached per `model_signature` (the last few models).

    Args:
        model: The compiled model.
        reshaped: Ids of geoms whose size or colour the run changes (a conveyor's recycled
            parcels): only their pose in the body is static.
    """
    key = f"{model_signature(model)}:{sorted(reshaped)}"
    hit = _cache.get(key)
    if hit is not None:
        _cache.move_to_end(key)
        return hit
    geoms, skipped = model_geometry(model)
    out = StaticGeometry(
        chunks=[
            static_chunk(g.entity, g.local)
            if g.geom_id in reshaped
            else static_chunk(g.entity, g.local, g.shape)
            for g in geoms
        ],
        bodies=frozenset(g.body_id for g in geoms),
        skipped=skipped,
        reshaped=tuple(g for g in geoms if g.geom_id in reshaped),
    )
    _cache[key] = out
    while len(_cache) > _CACHE_SIZE:
        _cache.popitem(last=False)
    return out
