"""MuJoCo geoms -> Rerun archetypes: the static geometry of a compiled model.

Every visible geom becomes one entity under its body (`world/bodies/<body>/geoms/<geom>`),
posed relative to the body by a static Transform3D. Meshes are built from the model's own
arrays (`mesh_vert`, `mesh_face`, `mesh_normal`, `mesh_facenormal`), so what is drawn is
exactly what MuJoCo simulates; primitives map to Boxes3D, Capsules3D, Cylinders3D and
Ellipsoids3D, planes to a quad, height fields to a grid mesh.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np
import rerun as rr

from .paths import geom_path, part

__all__ = [
    "GeomVisual",
    "body_names",
    "geom_archetype",
    "geom_rgba",
    "model_geometry",
    "visible_geoms",
]

_G = mujoco.mjtGeom
_DEFAULT_RGBA = np.array([0.5, 0.5, 0.5, 1.0], dtype=np.float32)
"""MuJoCo's default geom colour: a material's colour shows through only when rgba is this."""
_SOLID = rr.components.FillMode.Solid


@dataclass(frozen=True)
class GeomVisual:
    """One geom, ready to log.

    Attributes:
        geom_id: Index in the model.
        body_id: The body it is attached to.
        entity: Its entity path.
        local: Its pose in the body frame (static).
        shape: The archetype that draws it.
    """

    geom_id: int
    body_id: int
    entity: str
    local: rr.Transform3D
    shape: Any


def geom_rgba(model: mujoco.MjModel, geom: int) -> np.ndarray:
    """The colour MuJoCo renders a geom with (its material's unless rgba was set). Shape (4,)."""
    rgba = np.asarray(model.geom_rgba[geom], dtype=np.float32)
    mat = int(model.geom_matid[geom])
    if mat >= 0 and np.allclose(rgba, _DEFAULT_RGBA):
        return np.asarray(model.mat_rgba[mat], dtype=np.float32)
    return rgba


def visible_geoms(model: mujoco.MjModel) -> list[int]:
    """Geoms MuJoCo's viewer shows by default: group enabled in `mjvOption` and not transparent."""
    groups = np.asarray(mujoco.MjvOption().geomgroup)
    out = []
    for g in range(model.ngeom):
        group = int(np.clip(model.geom_group[g], 0, len(groups) - 1))
        if groups[group] and geom_rgba(model, g)[3] > 0.0:
            out.append(g)
    return out


def _rgba8(rgba: np.ndarray) -> np.ndarray:
    return np.clip(np.rint(np.asarray(rgba) * 255.0), 0, 255).astype(np.uint8)


def _vertex_normals(vertices: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """Area-weighted vertex normals. Shape (n_vertices, 3)."""
    a, b, c = (vertices[triangles[:, i]] for i in range(3))
    face_n = np.cross(b - a, c - a)
    normals = np.zeros_like(vertices)
    for i in range(3):
        np.add.at(normals, triangles[:, i], face_n)
    norm = np.linalg.norm(normals, axis=1, keepdims=True)
    return normals / np.where(norm > 0.0, norm, 1.0)


def _mesh(model: mujoco.MjModel, mesh: int, rgba: np.ndarray) -> rr.Mesh3D:
    vadr, vnum = int(model.mesh_vertadr[mesh]), int(model.mesh_vertnum[mesh])
    fadr, fnum = int(model.mesh_faceadr[mesh]), int(model.mesh_facenum[mesh])
    vertices = np.asarray(model.mesh_vert[vadr : vadr + vnum], dtype=np.float32)
    faces = np.asarray(model.mesh_face[fadr : fadr + fnum], dtype=np.int64)
    nadr, nnum = int(model.mesh_normaladr[mesh]), int(model.mesh_normalnum[mesh])
    face_normals = model.mesh_facenormal[fadr : fadr + fnum]
    if nnum == vnum and np.array_equal(face_normals, faces):
        # One normal per vertex: share the vertices.
        positions, triangles = vertices, faces.astype(np.uint32)
        normals = np.asarray(model.mesh_normal[nadr : nadr + nnum], dtype=np.float32)
    elif nnum > 0:
        # A normal per face corner (hard edges stay hard): one vertex per corner.
        corner_normals = model.mesh_normal[nadr + face_normals]
        positions = vertices[faces].reshape(-1, 3)
        normals = np.asarray(corner_normals, dtype=np.float32).reshape(-1, 3)
        triangles = np.arange(3 * fnum, dtype=np.uint32).reshape(-1, 3)
    else:
        positions, triangles = vertices, faces.astype(np.uint32)
        normals = _vertex_normals(vertices, faces)
    return rr.Mesh3D(
        vertex_positions=positions,
        triangle_indices=triangles,
        vertex_normals=normals,
        albedo_factor=_rgba8(rgba),
    )


def _plane(model: mujoco.MjModel, size: np.ndarray, rgba: np.ndarray) -> rr.Mesh3D:
    """A plane as a quad; a zero half-size (infinite in MuJoCo) uses the model's extent."""
    fallback = max(4.0 * float(model.stat.extent), 2.0)
    hx = float(size[0]) if size[0] > 0 else fallback
    hy = float(size[1]) if size[1] > 0 else fallback
    positions = np.array([[-hx, -hy, 0.0], [hx, -hy, 0.0], [hx, hy, 0.0], [-hx, hy, 0.0]])
    return rr.Mesh3D(
        vertex_positions=positions,
        triangle_indices=np.array([[0, 1, 2], [0, 2, 3]], dtype=np.uint32),
        vertex_normals=np.tile([0.0, 0.0, 1.0], (4, 1)),
        albedo_factor=_rgba8(rgba),
    )


def _hfield(model: mujoco.MjModel, hfield: int, rgba: np.ndarray) -> rr.Mesh3D:
    """A height field as a grid mesh (rows along y, columns along x, as MuJoCo lays it out)."""
    nrow, ncol = int(model.hfield_nrow[hfield]), int(model.hfield_ncol[hfield])
    sx, sy, sz, _ = (float(v) for v in model.hfield_size[hfield])
    adr = int(model.hfield_adr[hfield])
    z = np.asarray(model.hfield_data[adr : adr + nrow * ncol], dtype=np.float64).reshape(nrow, ncol)
    x, y = np.meshgrid(np.linspace(-sx, sx, ncol), np.linspace(-sy, sy, nrow))
    positions = np.stack([x, y, z * sz], axis=-1).reshape(-1, 3)
    idx = np.arange(nrow * ncol).reshape(nrow, ncol)
    a, b, c, d = idx[:-1, :-1], idx[:-1, 1:], idx[1:, 1:], idx[1:, :-1]
    triangles = np.concatenate(
        [np.stack([a, b, c], -1).reshape(-1, 3), np.stack([a, c, d], -1).reshape(-1, 3)]
    )
    return rr.Mesh3D(
        vertex_positions=positions,
        triangle_indices=triangles.astype(np.uint32),
        vertex_normals=_vertex_normals(positions, triangles),
        albedo_factor=_rgba8(rgba),
    )


def geom_archetype(model: mujoco.MjModel, geom: int) -> Any | None:
    """The archetype drawing `geom` in its own frame, or None for an SDF geom without a mesh.

    Sizes follow MuJoCo's conventions (`geom_size` holds half-sizes and radii, in [m]).
    """
    kind = int(model.geom_type[geom])
    size = np.asarray(model.geom_size[geom], dtype=np.float64)
    rgba = geom_rgba(model, geom)
    color = _rgba8(rgba)
    data_id = int(model.geom_dataid[geom])
    if kind == _G.mjGEOM_BOX:
        return rr.Boxes3D(half_sizes=[size], colors=[color], fill_mode=_SOLID)
    if kind == _G.mjGEOM_SPHERE:
        return rr.Ellipsoids3D(half_sizes=[[size[0]] * 3], colors=[color], fill_mode=_SOLID)
    if kind == _G.mjGEOM_ELLIPSOID:
        return rr.Ellipsoids3D(half_sizes=[size], colors=[color], fill_mode=_SOLID)
    if kind == _G.mjGEOM_CAPSULE:
        # MuJoCo: centred on the origin along z; Rerun: starts at the translation, along +z.
        return rr.Capsules3D(
            lengths=[2.0 * size[1]],
            radii=[size[0]],
            translations=[[0.0, 0.0, -size[1]]],
            colors=[color],
            fill_mode=_SOLID,
        )
    if kind == _G.mjGEOM_CYLINDER:
        return rr.Cylinders3D(
            lengths=[2.0 * size[1]],
            radii=[size[0]],
            centers=[[0.0, 0.0, 0.0]],
            colors=[color],
            fill_mode=_SOLID,
        )
    if kind == _G.mjGEOM_PLANE:
        return _plane(model, size, rgba)
    if kind == _G.mjGEOM_HFIELD:
        return _hfield(model, data_id, rgba)
    if kind in (_G.mjGEOM_MESH, _G.mjGEOM_SDF) and data_id >= 0:
        return _mesh(model, data_id, rgba)
    return None


def _unique_names(
    model: mujoco.MjModel, obj: mujoco.mjtObj, count: int, fallback: str
) -> list[str]:
    """Names of `count` objects: their MuJoCo name, `<fallback>_<index>` when unnamed, made
    unique once sanitized for entity paths."""
    names: list[str] = []
    seen: set[str] = set()
    for i in range(count):
        name = part(mujoco.mj_id2name(model, obj, i) or f"{fallback}_{i}")
        if name in seen:
            name = f"{name}_{i}"
        seen.add(name)
        names.append(name)
    return names


def body_names(model: mujoco.MjModel) -> list[str]:
    """Entity-path-safe, unique name of every body (`world` for body 0)."""
    return _unique_names(model, mujoco.mjtObj.mjOBJ_BODY, model.nbody, "body")


def model_geometry(model: mujoco.MjModel) -> tuple[list[GeomVisual], list[int]]:
    """Every visible geom of `model` as a GeomVisual, and the geoms that cannot be drawn.

    Returns:
        The drawable geoms (in model order) and the ids of visible geoms skipped (SDF geoms
        without a mesh, whose surface only exists as a plugin's distance function).
    """
    out: list[GeomVisual] = []
    skipped: list[int] = []
    bodies = body_names(model)
    geoms = _unique_names(model, mujoco.mjtObj.mjOBJ_GEOM, model.ngeom, "geom")
    for g in visible_geoms(model):
        shape = geom_archetype(model, g)
        if shape is None:
            skipped.append(g)
            continue
        body = int(model.geom_bodyid[g])
        w, x, y, z = (float(v) for v in model.geom_quat[g])
        out.append(
            GeomVisual(
                geom_id=g,
                body_id=body,
                entity=geom_path(bodies[body], geoms[g]),
                local=rr.Transform3D(
                    translation=np.asarray(model.geom_pos[g], dtype=np.float64),
                    quaternion=rr.Quaternion(xyzw=[x, y, z, w]),
                ),
                shape=shape,
            )
        )
    return out, skipped
