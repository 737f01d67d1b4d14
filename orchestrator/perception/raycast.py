"""The ray-cast camera: one `mj_multiRay` per frame, no OpenGL needed.

Each pixel's ray returns the geom it hits, the distance and the surface normal; colour is the
geom's (or its material's) RGBA, shaded as MuJoCo's renderer does it without specular
highlights: ambient light, plus Lambert diffuse light from the model's lights and the
camera's headlight. Visual meshes are replaced by the primitive collision geoms of their body
(the robot's capsules) when it has some: a ray against a mesh costs 10-50x a ray against a
primitive, and the robot is rarely what a vision task looks at. Geoms drawn mostly transparent
(alpha < 0.5) are not seen.
"""

from __future__ import annotations

import mujoco
import numpy as np

from .frame import Frame, Intrinsics

__all__ = ["RaycastCamera"]

_VISIBLE_GROUPS = 3
"""MuJoCo's renderer shows geom groups 0-2 by default; the ray-cast camera sees the same."""
_HIDDEN_GROUP = 5


class RaycastCamera:
    """Renders the model's cameras by ray casting (same `Frame` as the OpenGL camera).

    Args:
        model: The compiled model.
    """

    name = "raycast"

    def __init__(self, model: mujoco.MjModel) -> None:
        self.model = model
        m = model
        visual = m.geom_group < _VISIBLE_GROUPS
        mesh = visual & (m.geom_type == mujoco.mjtGeom.mjGEOM_MESH)
        standin = ~visual & (m.geom_type != mujoco.mjtGeom.mjGEOM_MESH)
        self._colour_of = np.arange(m.ngeom)
        """Geom whose colour a ray hitting this geom shows (a stand-in shows its mesh's)."""
        self._cast = visual.copy()
        for body in np.unique(m.geom_bodyid[mesh]):
            in_body = m.geom_bodyid == body
            if not np.any(standin & in_body):
                continue
            meshes = np.flatnonzero(mesh & in_body)
            self._cast[meshes] = False
            self._cast[standin & in_body] = True
            self._colour_of[standin & in_body] = meshes[0]
        self._mask = np.array([1, 0, 0, 0, 0, 0], np.uint8)
        self._rays: dict[int, tuple[bytes, np.ndarray, np.ndarray]] = {}
        """Camera id -> (its orientation, its pixels' rays in the world, their unit vectors)."""

    def render(
        self, data: mujoco.MjData, cam_id: int, intrinsics: Intrinsics, segmentation: bool
    ) -> Frame:
        """Render camera `cam_id` of the current state (segmentation always comes along).

        Rays are cast at every other pixel of every other row first; a pixel between cast
        ones whose neighbours all hit the same face of the same geom (same geom id, same
        normal) takes their interpolated inverse depth — exact on a plane — and only the
        others (edges, curved surfaces, the last row and column) get their own ray. On a
        tabletop scene that casts about a third of the rays.
        """
        m = self.model
        rgba = self._rgba()
        h, w = intrinsics.height, intrinsics.width
        pos = data.cam_xpos[cam_id].copy()
        rot = data.cam_xmat[cam_id].reshape(3, 3).copy()
        vec, view = self._world_rays(cam_id, intrinsics, rot)
        geom = np.full((h, w), -2, np.int32)  # -2: not cast yet
        dist = np.zeros((h, w))
        normal = np.zeros((h, w, 3))
        saved = m.geom_group.copy()
        try:
            # cast only at what is drawn: those geoms in group 0, every other one out of reach
            m.geom_group[:] = np.where(self._cast & (rgba[:, 3] >= 0.5), 0, _HIDDEN_GROUP)
            coarse = np.zeros((h, w), bool)
            coarse[::2, ::2] = True
            self._cast_rays(data, pos, vec, coarse, geom, dist, normal)
            self._fill_between(geom, dist, normal)
            self._cast_rays(data, pos, vec, geom == -2, geom, dist, normal)
        finally:
            m.geom_group[:] = saved
        hit = geom >= 0
        depth = np.where(hit, dist, 0.0).astype(np.float32)
        rgb = self._shade(data, rgba, geom[hit], normal[hit], view[hit], (h, w), hit)
        return Frame(
            camera=m.camera(cam_id).name,
            backend=self.name,
            rgb=rgb,
            depth=depth,
            seg=np.where(hit, geom, -1).astype(np.int32) if segmentation else None,
            intrinsics=intrinsics,
            pos=pos,
            rot=rot,
        )

    def _world_rays(
        self, cam_id: int, intrinsics: Intrinsics, rot: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Each pixel's ray in the world (z component -1 in the camera frame) and its unit
        vector, shapes (h, w, 3); kept while the camera does not turn (a fixed camera: always).
        """
        key = (
            rot.tobytes() + np.array([intrinsics.width, intrinsics.height, intrinsics.fy]).tobytes()
        )
        cached = self._rays.get(cam_id)
        if cached is not None and cached[0] == key:
            return cached[1], cached[2]
        local = intrinsics.ray_directions()
        # three columns by hand: a BLAS matrix product of (n, 3) by (3, 3) spins up threads
        vec = local[:, :1] * rot[:, 0] + local[:, 1:2] * rot[:, 1] + local[:, 2:] * rot[:, 2]
        vec = vec.reshape(intrinsics.height, intrinsics.width, 3)
        view = (vec / np.sqrt(np.sum(vec * vec, axis=-1, keepdims=True))).astype(np.float32)
        self._rays[cam_id] = (key, vec, view)
        return vec, view

    def _cast_rays(
        self,
        data: mujoco.MjData,
        pos: np.ndarray,
        vec: np.ndarray,
        which: np.ndarray,
        geom: np.ndarray,
        dist: np.ndarray,
        normal: np.ndarray,
    ) -> None:
        n = int(which.sum())
        if n == 0:
            return
        g = np.empty(n, np.int32)
        d = np.empty(n)
        nrm = np.empty(3 * n)
        rays = np.ascontiguousarray(vec[which]).ravel()
        mujoco.mj_multiRay(self.model, data, pos, rays, self._mask, 1, -1, g, d, nrm, n, 1e3)
        geom[which] = g
        dist[which] = d
        normal[which] = nrm.reshape(n, 3)

    @staticmethod
    def _fill_between(geom: np.ndarray, dist: np.ndarray, normal: np.ndarray) -> None:
        """Fill the pixels between cast ones that lie on one face (see `render`)."""
        h, w = geom.shape
        r1, c1 = (h - 1) // 2 * 2, (w - 1) // 2 * 2  # last even row / column with a neighbour
        cg = geom[: r1 + 1 : 2, : c1 + 1 : 2]
        cd = dist[: r1 + 1 : 2, : c1 + 1 : 2]
        cn = normal[: r1 + 1 : 2, : c1 + 1 : 2]
        # one integer per cast pixel: its geom and its quantized normal (a face of the geom)
        q = np.rint((cn + 1.0) * 1e4).astype(np.int64)
        face = ((cg.astype(np.int64) * 20001 + q[..., 0]) * 20001 + q[..., 1]) * 20001 + q[..., 2]
        face[cg < 0] = -1
        inv = np.where(cg >= 0, 1.0 / np.where(cd > 0.0, cd, 1.0), 0.0)
        a, b = slice(None, -1), slice(1, None)
        all_ = slice(None)
        for (rows, cols), parts in (
            ((slice(0, r1 + 1, 2), slice(1, c1, 2)), ((all_, a), (all_, b))),
            ((slice(1, r1, 2), slice(0, c1 + 1, 2)), ((a, all_), (b, all_))),
            ((slice(1, r1, 2), slice(1, c1, 2)), ((a, a), (a, b), (b, a), (b, b))),
        ):
            f0 = face[parts[0]]
            same = f0 >= 0
            nothing = cg[parts[0]] == -1
            for part in parts[1:]:
                same &= face[part] == f0
                nothing &= cg[part] == -1
            mean_inv = np.add.reduce([inv[part] for part in parts]) / len(parts)
            tg, td, tn = geom[rows, cols], dist[rows, cols], normal[rows, cols]
            tg[same] = cg[parts[0]][same]
            td[same] = 1.0 / mean_inv[same]
            tn[same] = cn[parts[0]][same]
            tg[nothing] = -1  # nothing hit all around: nothing in between either

    def _rgba(self) -> np.ndarray:
        m = self.model
        rgba = m.geom_rgba.copy()
        mat = m.geom_matid
        has_mat = mat >= 0
        rgba[has_mat] = m.mat_rgba[mat[has_mat]]
        return rgba[self._colour_of]

    def _shade(
        self,
        data: mujoco.MjData,
        rgba: np.ndarray,
        geom: np.ndarray,
        normal: np.ndarray,
        view: np.ndarray,
        shape: tuple[int, int],
        hit: np.ndarray,
    ) -> np.ndarray:
        m = self.model
        nx, ny, nz = (normal[:, i].astype(np.float32) for i in range(3))
        facing = nx * view[:, 0] + ny * view[:, 1] + nz * view[:, 2]
        toward = np.where(facing > 0.0, np.float32(-1.0), np.float32(1.0))  # the eye's side
        head = m.vis.headlight
        active = np.flatnonzero(m.light_active)
        ambient = np.asarray(head.ambient, np.float32) + m.light_ambient[active].sum(0)
        terms = [(np.abs(facing), np.asarray(head.diffuse, np.float32))]
        for i in active:
            dx, dy, dz = (float(v) for v in data.light_xdir[i])
            lam = np.clip(-(nx * dx + ny * dy + nz * dz) * toward, 0.0, None)
            terms.append((lam, m.light_diffuse[i].astype(np.float32)))
        base = rgba[geom, :3].astype(np.float32)
        out = np.zeros((*shape, 3), np.uint8)
        for c in range(3):  # per channel on flat arrays: cheaper than (n, 3) temporaries
            light = np.full(len(geom), ambient[c], np.float32)
            for lam, colour in terms:
                light += lam * colour[c]
            light *= base[:, c]
            out[..., c][hit] = np.rint(np.clip(light, 0.0, 1.0) * np.float32(255.0))
        return out
