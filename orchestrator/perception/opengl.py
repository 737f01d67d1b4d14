"""The OpenGL camera: MuJoCo's own renderer on an offscreen context (EGL, OSMesa or GLFW)."""

from __future__ import annotations

import hashlib

import mujoco
import numpy as np

from .frame import Frame, Intrinsics

__all__ = ["OpenGLCamera"]

_OFF_FLAGS = (
    mujoco.mjtRndFlag.mjRND_SHADOW,
    mujoco.mjtRndFlag.mjRND_REFLECTION,
    mujoco.mjtRndFlag.mjRND_SKYBOX,
    mujoco.mjtRndFlag.mjRND_FOG,
    mujoco.mjtRndFlag.mjRND_HAZE,
)
"""Effects a camera for vision does without: shadows alone cost 20x the rest of a frame on a
software OpenGL (llvmpipe), and none of them helps colour segmentation."""


_UPLOADED = (
    "mesh_vert", "mesh_normal", "mesh_face", "mesh_texcoord", "mesh_vertadr", "mesh_vertnum",
    "tex_data", "tex_width", "tex_height", "hfield_data", "hfield_size", "skin_vert",
    "geom_type", "geom_dataid", "mat_texid",
)  # fmt: skip
"""What `mjr_makeContext` uploads (meshes, textures, height fields, skins, plane geometry):
two models equal in these, in their planes' sizes (and in the offscreen buffer's size and
samples) share a context. Other geoms' sizes are not uploaded: boxes, spheres and capsules are
unit shapes scaled when drawn, so parcels of new sizes every episode keep the context."""


class _SharedGL:
    """One OpenGL context per process, and the `MjrContext` of the last model it rendered.

    Making an EGL context costs ~160 ms and an `MjrContext` for the Panda ~110 ms: per episode,
    that is most of a short run's rendering. Episodes of one scenario differ in object poses and
    colours, never in what the context holds, so a batch worker makes both once.
    """

    def __init__(self, context_cls: type) -> None:
        self.context_cls = context_cls
        self.gl = context_cls(64, 64)  # rendering goes to MuJoCo's own offscreen buffer
        self.key = b""
        self.con: mujoco.MjrContext | None = None

    def context_for(self, model: mujoco.MjModel, key: bytes) -> mujoco.MjrContext:
        """The `MjrContext` for `model` (whose `_upload_key` is `key`), made current; rebuilt
        only when the uploads differ from the last model's."""
        self.gl.make_current()
        if self.con is None or key != self.key:
            if self.con is not None:
                self.con.free()
            self.con = mujoco.MjrContext(model, mujoco.mjtFontScale.mjFONTSCALE_50.value)
            self.con.readDepthMap = mujoco.mjtDepthMap.mjDEPTH_ZEROFAR
            self.key = key
        mujoco.mjr_setBuffer(mujoco.mjtFramebuffer.mjFB_OFFSCREEN.value, self.con)
        return self.con


def _upload_key(model: mujoco.MjModel) -> bytes:
    h = hashlib.blake2b(digest_size=16)
    glob = model.vis.global_
    h.update(np.array([glob.offwidth, glob.offheight, model.vis.quality.offsamples]).tobytes())
    for name in _UPLOADED:
        h.update(np.ascontiguousarray(getattr(model, name)).tobytes())
    planes = model.geom_type == mujoco.mjtGeom.mjGEOM_PLANE
    h.update(np.ascontiguousarray(model.geom_size[planes]).tobytes())
    return h.digest()


_shared: dict[type, _SharedGL] = {}


class OpenGLCamera:
    """Renders the model's cameras with MuJoCo's renderer: colour and depth from one
    pass (`mjr_readPixels` reads both), segmentation from a second pass when asked for.

    Args:
        model: The compiled model (its offscreen buffer must hold the largest camera).
        context_cls: The OpenGL context class (`mujoco.GLContext`, `mujoco.egl.GLContext`...).
    """

    name = "opengl"

    def __init__(self, model: mujoco.MjModel, context_cls: type) -> None:
        self.model = model
        if context_cls not in _shared:
            _shared[context_cls] = _SharedGL(context_cls)
        self._gl = _shared[context_cls]
        self._key = _upload_key(model)
        self._con = self._gl.context_for(model, self._key)
        self._scene = mujoco.MjvScene(model, maxgeom=max(1000, 4 * model.ngeom))
        for flag in _OFF_FLAGS:
            self._scene.flags[flag] = 0
        self._opt = mujoco.MjvOption()
        self._cam = mujoco.MjvCamera()
        self._cam.type = mujoco.mjtCamera.mjCAMERA_FIXED
        extent = float(model.stat.extent)
        self._near = np.float32(model.vis.map.znear * extent)
        self._far = np.float32(model.vis.map.zfar * extent)

    def render(
        self, data: mujoco.MjData, cam_id: int, intrinsics: Intrinsics, segmentation: bool
    ) -> Frame:
        """Render camera `cam_id` of the current state."""
        self._con = self._gl.context_for(self.model, self._key)  # another camera may have used it
        w, h = intrinsics.width, intrinsics.height
        rect = mujoco.MjrRect(0, 0, w, h)
        self._cam.fixedcamid = cam_id
        mujoco.mjv_updateScene(
            self.model,
            data,
            self._opt,
            None,
            self._cam,
            mujoco.mjtCatBit.mjCAT_ALL.value,
            self._scene,
        )
        rgb = np.empty((h, w, 3), np.uint8)
        zbuf = np.empty((h, w), np.float32)
        mujoco.mjr_render(rect, self._scene, self._con)
        mujoco.mjr_readPixels(rgb, zbuf, rect, self._con)
        seg = self._segmentation(rect, h, w) if segmentation else None
        return Frame(
            camera=self.model.camera(cam_id).name,
            backend=self.name,
            rgb=np.flipud(rgb).copy(),
            depth=np.flipud(self._metric_depth(zbuf)).copy(),
            seg=None if seg is None else np.flipud(seg).copy(),
            intrinsics=intrinsics,
            pos=data.cam_xpos[cam_id].copy(),
            rot=data.cam_xmat[cam_id].reshape(3, 3).copy(),
        )

    def _metric_depth(self, zbuf: np.ndarray) -> np.ndarray:
        # reversed-Z perspective depth (MuJoCo's mjDEPTH_ZEROFAR) back to metres; in float32,
        # within 6e-8 m of mujoco.Renderer's float64 and half its cost; the far plane (nothing
        # hit) becomes 0
        near, far = self._near, self._far
        c = np.float32(-0.5) * (-(far + near) / (far - near)) - np.float32(0.5)
        d = np.float32(-0.5) * (-(np.float32(2) * far * near) / (far - near))
        with np.errstate(divide="ignore"):
            depth = d / (zbuf + c)
        depth[(zbuf <= 0.0) | (depth >= np.float32(0.999) * far)] = 0.0
        return depth

    def _segmentation(self, rect: mujoco.MjrRect, h: int, w: int) -> np.ndarray:
        scene = self._scene
        scene.flags[mujoco.mjtRndFlag.mjRND_SEGMENT] = 1
        scene.flags[mujoco.mjtRndFlag.mjRND_IDCOLOR] = 1
        try:
            mujoco.mjr_render(rect, scene, self._con)
            ids = np.empty((h, w, 3), np.uint8)
            mujoco.mjr_readPixels(ids, None, rect, self._con)
        finally:
            scene.flags[mujoco.mjtRndFlag.mjRND_SEGMENT] = 0
            scene.flags[mujoco.mjtRndFlag.mjRND_IDCOLOR] = 0
        segid = ids[..., 0].astype(np.int32) | (ids[..., 1].astype(np.int32) << 8)
        segid |= ids[..., 2].astype(np.int32) << 16
        lut = np.full(scene.ngeom + 1, -1, np.int32)  # seg id 0 is the background
        geom = int(mujoco.mjtObj.mjOBJ_GEOM)
        for g in scene.geoms[: scene.ngeom]:
            if g.segid >= 0 and g.objtype == geom:
                lut[g.segid + 1] = g.objid
        return lut[np.clip(segid, 0, scene.ngeom)]

    def close(self) -> None:
        """Nothing to free: the context is kept for the process's next episode."""
