"""From blobs to detections: 3D pose from depth, intrinsics and the camera pose; confidence."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np

from ..world.pose import quat_from_yaw
from .colours import HsvBox
from .frame import Frame
from .vision import Blob, find_blobs

__all__ = ["Detection", "detect_objects", "localize", "quantile", "row_ends", "sort_detections"]

_TOP_BAND_M = 0.004
"""Points this close below the highest part of a blob belong to its top face [m]."""


@dataclass(frozen=True)
class Detection:
    """An object found in an image.

    Attributes:
        id: Index in the sorted list of its `detect` call.
        cls: Colour class.
        pos: Centre of its top face in the world [m]. Shape (3,).
        yaw: Heading of its top face's long side (a square: of one side, in (-45, 45]) [rad].
        confidence: 0..1; below 0.5 for blobs cut by the border, occluded or of an ambiguous
            colour.
        pixels: Blob area [px].
        bbox: `(x, y, width, height)` [px].
        size_m: Top face extent `(long side, short side)` [m].
        camera: Camera that saw it.
    """

    id: int
    cls: str
    pos: np.ndarray
    yaw: float
    confidence: float
    pixels: int
    bbox: tuple[int, int, int, int]
    size_m: tuple[float, float]
    camera: str

    def to_blackboard(self) -> dict[str, Any]:
        """The blackboard form: plain lists and numbers (`pose` is a pose value)."""
        return {
            "id": self.id,
            "class": self.cls,
            "pose": {
                "pos": [round(float(v), 6) for v in self.pos],
                "quat": [round(float(v), 8) for v in quat_from_yaw(self.yaw)],
            },
            "confidence": self.confidence,
            "pixels": self.pixels,
            "bbox": list(self.bbox),
            "size_m": [round(s, 5) for s in self.size_m],
            "camera": self.camera,
        }


def localize(
    blob: Blob, frame: Frame, min_pixels: int, depth_noise_m: float = 0.0
) -> list[Detection]:
    """The detections (id 0) of `blob` in `frame`: one per top face it holds; none if it has
    too few valid depths.

    The blob's pixels are back-projected to world points; those within a few millimetres of
    its highest part form the top face (side faces seen in perspective drop out). Two objects
    of one colour close together make one blob (their sides bridge the gap) but two top faces:
    each top face that is a connected region of the image of at least a fifth of the largest
    one is reported on its own. Position: the mean of the top face's points (z: their median).
    Yaw and size: `cv2.minAreaRect` of the top face's points in the world xy plane.
    """
    pts = frame.backproject(blob.rows, blob.cols)
    ok = np.isfinite(pts[:, 0])
    if ok.sum() < 3:
        return []
    z_top = quantile(pts[ok, 2], 0.95)
    top = np.flatnonzero(ok & (pts[:, 2] >= z_top - _TOP_BAND_M - 3.0 * depth_noise_m))
    if len(top) < 3:
        return []
    faces = _top_faces(blob, top, min_pixels)
    if len(faces) <= 1:
        det = _detection(blob, pts[top], frame, _confidence(blob, min_pixels))
        return [] if det is None else [det]
    out = []
    for face in faces:
        part = blob.part(face)
        det = _detection(part, pts[face], frame, _confidence(part, min_pixels))
        if det is not None:
            out.append(det)
    return out


def _top_faces(blob: Blob, top: np.ndarray, min_pixels: int) -> list[np.ndarray]:
    """Indices (into the blob's pixels) of each separate top face among `top`."""
    x, y, w, h = blob.bbox
    rows, cols = blob.rows[top] - y, blob.cols[top] - x
    mask = np.zeros((h, w), np.uint8)
    mask[rows, cols] = 1
    n, labels = cv2.connectedComponents(mask, connectivity=8)
    if n <= 2:
        return [top]
    label = labels[rows, cols]
    areas = np.bincount(label, minlength=n)[1:]
    keep = [i + 1 for i in np.flatnonzero(areas >= max(min_pixels / 2, 0.2 * areas.max()))]
    return [top[label == k] for k in keep]


def quantile(values: np.ndarray, q: float) -> float:
    """`np.quantile(values, q)` (linear interpolation; q = 0.5: the median) from one
    `np.partition`, without the general function's overhead (4x its cost on a blob's few
    hundred values). `values`: shape (n,), n >= 1."""
    n = len(values)
    pos = n * q + (1.0 - q) - 1.0  # numpy's virtual index for the linear method
    lo = min(max(int(math.floor(pos)), 0), n - 1)
    hi = min(lo + 1, n - 1)
    part = np.partition(values, (lo, hi))
    a, b, t = float(part[lo]), float(part[hi]), pos - math.floor(pos)
    return a + (b - a) * t if t < 0.5 else b - (b - a) * (1.0 - t)


def _detection(blob: Blob, top: np.ndarray, frame: Frame, confidence: float) -> Detection | None:
    """The detection of `blob` whose top face is the world points `top` (shape (n, 3))."""
    if len(top) < 3:
        return None
    pos = np.array([top[:, 0].mean(), top[:, 1].mean(), quantile(top[:, 2], 0.5)])
    rect = cv2.minAreaRect((top[:, :2] * 1000.0).astype(np.float32))
    corners = cv2.boxPoints(rect).astype(float) / 1000.0
    e1, e2 = corners[1] - corners[0], corners[2] - corners[1]
    pixel_m = quantile(frame.depth[blob.rows, blob.cols], 0.5) / frame.intrinsics.fy
    l1, l2 = np.linalg.norm(e1) + pixel_m, np.linalg.norm(e2) + pixel_m
    long_edge, size = (e1, (l1, l2)) if l1 >= l2 else (e2, (l2, l1))
    yaw = math.atan2(long_edge[1], long_edge[0])
    if size[1] > 0.85 * size[0]:  # square: a quarter turn looks the same
        yaw = _wrap(yaw, math.pi / 2)
    else:
        yaw = _wrap(yaw, math.pi)
    return Detection(
        id=0,
        cls=blob.cls,
        pos=pos,
        yaw=yaw,
        confidence=confidence,
        pixels=blob.pixels,
        bbox=blob.bbox,
        size_m=(float(size[0]), float(size[1])),
        camera=frame.camera,
    )


def _wrap(angle: float, period: float) -> float:
    """`angle` into (-period / 2, period / 2]."""
    a = math.fmod(angle + period / 2, period)
    a = a + period if a <= 0.0 else a
    return a - period / 2


def row_ends(rows: np.ndarray) -> np.ndarray:
    """Indices of the first and the last pixel of each row among pixels in row-major order
    (`rows` ascending, columns ascending within a row). They span the same convex hull as all
    the pixels, so the same `cv2.minAreaRect`, with a tenth of the points. Shape (2 * rows,)."""
    step = np.flatnonzero(rows[1:] != rows[:-1])  # the last pixel of each row but the last
    return np.concatenate(([0], step, step + 1, [len(rows) - 1]))


def _confidence(blob: Blob, min_pixels: int) -> float:
    """How much to trust a blob: whole (not cut by the border), compact (not occluded: it
    fills its minimum-area rectangle), of an unambiguous colour, and not tiny."""
    ends = row_ends(blob.rows)
    pts = np.column_stack([blob.cols[ends], blob.rows[ends]]).astype(np.float32)
    (_, _), (w, h), _ = cv2.minAreaRect(pts)
    fill = blob.pixels / ((w + 1.0) * (h + 1.0))
    score = min(1.0, max(0.0, (fill - 0.55) / 0.3))
    score *= min(1.0, blob.hue_margin / 3.0)
    score *= min(1.0, blob.pixels / (3.0 * min_pixels))
    if blob.cut:
        score *= 0.3
    return round(score, 3)


def sort_detections(found: list[Detection]) -> list[Detection]:
    """Sorted by class, then confidence (highest first), then x and y; numbered in order."""
    ordered = sorted(
        found,
        key=lambda d: (d.cls, -d.confidence, round(float(d.pos[0]), 4), round(float(d.pos[1]), 4)),
    )
    return [
        Detection(i, d.cls, d.pos, d.yaw, d.confidence, d.pixels, d.bbox, d.size_m, d.camera)
        for i, d in enumerate(ordered)
    ]


def detect_objects(
    frame: Frame,
    classes: Mapping[str, Sequence[HsvBox]],
    min_pixels: int = 30,
    roi: tuple[int, int, int, int] | None = None,
    depth_noise_m: float = 0.0,
) -> list[Detection]:
    """Every object of a colour class in `frame`, localized and sorted (`sort_detections`).

    Args:
        frame: A rendered frame (RGB and depth).
        classes: Class name -> its HSV boxes.
        min_pixels: Smallest blob reported [px].
        roi: Region of interest `(x0, y0, x1, y1)` [px], end exclusive; None: the whole image.
        depth_noise_m: Std. dev. of the depth image's noise [m] (widens the top-face band).
    """
    found = []
    for blob in find_blobs(frame.rgb, classes, roi, min_pixels):
        found += localize(blob, frame, min_pixels, depth_noise_m)
    return sort_detections(found)
