"""Self-collision proxies: one capsule per link, fitted to its collision mesh.

Mesh-to-mesh collision between the links would dominate the physics step, so the links of a
robot do not collide with each other through their meshes. Instead each link gets a capsule
(principal axis of its mesh vertices, radius and ends enclosing `coverage` of them) that
collides only with the capsules of links at least `min_gap` joints away, through explicit
contact pairs: capsule-capsule tests cost a few nanoseconds each. Pairs that already touch at
the robot's home pose are left out (neighbours whose capsules overlap by construction).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    import mujoco

__all__ = ["PROXY_GROUP", "CapsuleProxy", "add_self_collision_proxies", "proxy_name"]

PROXY_GROUP = 4
"""Geom group of the proxies (hidden in viewers, like MuJoCo's collision groups)."""


@dataclass(frozen=True)
class CapsuleProxy:
    """A capsule in a body's frame: `start` -> `end` [m], `radius` [m]."""

    body: str
    start: tuple[float, float, float]
    end: tuple[float, float, float]
    radius: float


def proxy_name(body: str) -> str:
    """Geom name of `body`'s proxy capsule."""
    return f"{body}_proxy"


def fit_capsule(points: np.ndarray, coverage: float = 0.97) -> tuple[np.ndarray, np.ndarray, float]:
    """A capsule along the principal axis of `points` (shape (k, 3)) enclosing `coverage` of
    them: ends and radius [m]. A full enclosure would be dominated by a link's flanges."""
    centre = points.mean(axis=0)
    _, _, vt = np.linalg.svd(points - centre, full_matrices=False)
    axis = vt[0]
    along = (points - centre) @ axis
    radial = np.linalg.norm((points - centre) - np.outer(along, axis), axis=1)
    radius = float(np.quantile(radial, coverage))
    lo, hi = np.quantile(along, [1.0 - coverage, coverage])
    lo, hi = min(lo + radius, 0.0), max(hi - radius, 0.0)
    return centre + lo * axis, centre + hi * axis, radius


def _mesh_points(model: mujoco.MjModel, body: int) -> np.ndarray | None:
    import mujoco

    pts = []
    for g in range(model.ngeom):
        if model.geom_bodyid[g] != body or model.geom_type[g] != mujoco.mjtGeom.mjGEOM_MESH:
            continue
        mid = model.geom_dataid[g]
        adr, n = model.mesh_vertadr[mid], model.mesh_vertnum[mid]
        verts = model.mesh_vert[adr : adr + n]
        rot = np.zeros(9)
        mujoco.mju_quat2Mat(rot, model.geom_quat[g])
        pts.append(verts @ rot.reshape(3, 3).T + model.geom_pos[g])
    return np.vstack(pts) if pts else None


def _chain_gap(model: mujoco.MjModel, a: int, b: int) -> int:
    """Number of joints between two bodies along the kinematic tree."""

    def ancestry(body: int) -> list[int]:
        out = [body]
        while body > 0:
            body = int(model.body_parentid[body])
            out.append(body)
        return out

    pa, pb = ancestry(a), ancestry(b)
    common = next(x for x in pa if x in pb)
    joints = 0
    for chain in (pa, pb):
        for body in chain[: chain.index(common)]:
            joints += int(model.body_jntnum[body])
    return joints


def _plan(
    spec: mujoco.MjSpec, bodies: tuple[str, ...], home_qpos: tuple[float, ...], min_gap: int
) -> tuple[tuple[CapsuleProxy, ...], tuple[tuple[str, str], ...]]:
    """Fit the proxies on a compiled copy of `spec` and choose the pairs (the costly part)."""
    import mujoco

    model = spec.copy().compile()
    proxies = []
    for name in bodies:
        pts = _mesh_points(model, model.body(name).id)
        if pts is not None:
            start, end, radius = fit_capsule(pts)
            proxies.append(CapsuleProxy(name, tuple(start.tolist()), tuple(end.tolist()), radius))
    trial = spec.copy()
    _add_geoms(trial, proxies)
    model = trial.compile()
    data = mujoco.MjData(model)
    data.qpos[: len(home_qpos)] = home_qpos
    mujoco.mj_forward(model, data)
    pairs = []
    fromto = np.zeros(6)
    for i, a in enumerate(proxies):
        for b in proxies[i + 1 :]:
            if _chain_gap(model, model.body(a.body).id, model.body(b.body).id) < min_gap:
                continue
            ga, gb = model.geom(proxy_name(a.body)).id, model.geom(proxy_name(b.body)).id
            if mujoco.mj_geomDistance(model, data, ga, gb, 0.05, fromto) > 0.0:
                pairs.append((a.body, b.body))
    return tuple(proxies), tuple(pairs)


def _add_geoms(spec: mujoco.MjSpec, proxies: list[CapsuleProxy] | tuple[CapsuleProxy, ...]) -> None:
    import mujoco

    for p in proxies:
        g = spec.body(p.body).add_geom(
            name=proxy_name(p.body),
            type=mujoco.mjtGeom.mjGEOM_CAPSULE,
            fromto=[*p.start, *p.end],
            size=[p.radius, 0.0, 0.0],
        )
        g.contype, g.conaffinity = 0, 0
        g.group = PROXY_GROUP
        g.density = 0.0
        g.rgba = [0.3, 0.6, 0.9, 0.25]


_PLANS: dict[tuple, tuple[tuple[CapsuleProxy, ...], tuple[tuple[str, str], ...]]] = {}


def add_self_collision_proxies(
    spec: mujoco.MjSpec,
    robot: str,
    bodies: tuple[str, ...],
    home_qpos: tuple[float, ...],
    min_gap: int = 3,
) -> tuple[tuple[str, str], ...]:
    """Add a proxy capsule to each of `bodies` that has collision meshes, and a contact pair
    for every two proxies at least `min_gap` joints apart that do not touch at `home_qpos`.

    The fit is computed once per process for each `robot` name (it compiles the model).

    Returns:
        The proxy pairs added (body names).
    """
    key = (robot, bodies, tuple(home_qpos), min_gap)
    if key not in _PLANS:
        _PLANS[key] = _plan(spec, bodies, tuple(home_qpos), min_gap)
    proxies, pairs = _PLANS[key]
    _add_geoms(spec, proxies)
    for a, b in pairs:
        pair = spec.add_pair(geomname1=proxy_name(a), geomname2=proxy_name(b))
        pair.condim = 1
    return pairs
