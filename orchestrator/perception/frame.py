"""A rendered camera frame and the pinhole geometry that turns its pixels into world points."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["Frame", "Intrinsics"]


@dataclass(frozen=True)
class Intrinsics:
    """Pinhole intrinsics of a MuJoCo camera (square pixels, principal point at the centre).

    Attributes:
        width: Image width [px].
        height: Image height [px].
        fx: Focal length along image columns [px].
        fy: Focal length along image rows [px].
        cx: Principal point column [px] (pixel i spans [i, i + 1)).
        cy: Principal point row [px].
    """

    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float

    @classmethod
    def from_fovy(cls, width: int, height: int, fovy_deg: float) -> Intrinsics:
        """Intrinsics of a camera with vertical field of view `fovy_deg` [deg]."""
        f = 0.5 * height / math.tan(math.radians(fovy_deg) / 2.0)
        return cls(width, height, f, f, width / 2.0, height / 2.0)

    def matrix(self) -> np.ndarray:
        """The 3x3 camera matrix K (OpenCV convention: +x right, +y down, +z forward)."""
        return np.array([[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]])

    def ray_directions(self) -> np.ndarray:
        """Direction of each pixel centre's ray in MuJoCo's camera frame (x right, y up, looking
        along -z), scaled so that its z component is -1: a distance along it is a depth.
        Shape (height * width, 3), row-major over the image."""
        u = (np.arange(self.width) + 0.5 - self.cx) / self.fx
        v = (np.arange(self.height) + 0.5 - self.cy) / self.fy
        uu, vv = np.meshgrid(u, v)
        return np.stack([uu, -vv, -np.ones_like(uu)], axis=-1).reshape(-1, 3)


@dataclass(frozen=True)
class Frame:
    """One rendered image of a camera, with its depth, segmentation and pose.

    Attributes:
        camera: Camera name.
        backend: Renderer that made it: `opengl` or `raycast`.
        rgb: Colour image. Shape (height, width, 3), uint8.
        depth: Depth along the optical axis [m]; 0 where nothing was hit. Shape (height,
            width), float32.
        seg: Geom id seen at each pixel, -1 for none. Shape (height, width), int32; None when
            segmentation was not rendered.
        intrinsics: The camera's pinhole intrinsics.
        pos: Camera position in the world [m]. Shape (3,).
        rot: Camera orientation in the world (columns: its x right, y up, z backwards axes).
            Shape (3, 3).
    """

    camera: str
    backend: str
    rgb: np.ndarray
    depth: np.ndarray
    seg: np.ndarray | None
    intrinsics: Intrinsics
    pos: np.ndarray
    rot: np.ndarray

    def backproject(self, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
        """World points [m] seen at pixels (`rows`, `cols`) (their centres), from the depth
        image. Pixels without depth give NaN. Shape (n, 3)."""
        k = self.intrinsics
        z = self.depth[rows, cols].astype(float)
        x = (cols + 0.5 - k.cx) / k.fx * z
        y = -(rows + 0.5 - k.cy) / k.fy * z
        # rot @ (x, y, -z) + pos, a row at a time: a matmul of a few hundred points goes to
        # BLAS, whose threads then spin on the other core for longer than the product takes
        r = self.rot
        pts = np.empty((len(z), 3))
        for i in range(3):
            pts[:, i] = r[i, 0] * x + r[i, 1] * y - r[i, 2] * z + self.pos[i]
        pts[z <= 0.0] = np.nan
        return pts

    def project(self, points: np.ndarray) -> np.ndarray:
        """Pixel coordinates (column, row; continuous) of world points. Shape (n, 2); points
        behind the camera give NaN."""
        local = (np.asarray(points, float) - self.pos) @ self.rot
        z = -local[:, 2]
        k = self.intrinsics
        with np.errstate(divide="ignore", invalid="ignore"):
            u = k.cx + k.fx * local[:, 0] / z
            v = k.cy - k.fy * local[:, 1] / z
        out = np.stack([u, v], axis=-1)
        out[z <= 0.0] = np.nan
        return out
