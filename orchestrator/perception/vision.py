"""Colour segmentation with OpenCV: pixels of each colour class, grouped into blobs."""

from __future__ import annotations

import functools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import cv2
import numpy as np

from .colours import HsvBox

__all__ = ["Blob", "circular_mean_hue", "components", "find_blobs", "hue_margin"]

_KERNEL = np.ones((3, 3), np.uint8)


@dataclass(frozen=True)
class Blob:
    """A connected region of one colour class in an image.

    Attributes:
        cls: Colour class name.
        rows: Row of each pixel, in row-major order (rows ascending, then columns). Shape (n,).
        cols: Column of each pixel. Shape (n,).
        bbox: Bounding box `(x, y, width, height)` [px].
        cut: It touches the image's (or the region of interest's) border.
        bounds: The region it was found in `(x0, y0, x1, y1)` [px], end exclusive.
        hue_margin: Hue steps (OpenCV units) from the blob's mean hue (circular) to the
            nearest hue outside its class: small means its colour is ambiguous.
    """

    cls: str
    rows: np.ndarray
    cols: np.ndarray
    bbox: tuple[int, int, int, int]
    cut: bool
    hue_margin: float
    bounds: tuple[int, int, int, int]

    @property
    def pixels(self) -> int:
        """Area [px]."""
        return len(self.rows)

    def part(self, index: np.ndarray) -> Blob:
        """The blob made of the pixels `index` of this one (its box and cut recomputed)."""
        rows, cols = self.rows[index], self.cols[index]
        r0, r1, c0, c1 = int(rows.min()), int(rows.max()), int(cols.min()), int(cols.max())
        x0, y0, x1, y1 = self.bounds
        cut = c0 == x0 or r0 == y0 or c1 == x1 - 1 or r1 == y1 - 1
        bbox = (c0, r0, c1 - c0 + 1, r1 - r0 + 1)
        return Blob(self.cls, rows, cols, bbox, cut, self.hue_margin, self.bounds)


@functools.lru_cache(maxsize=64)
def _outside_hues(boxes: tuple[HsvBox, ...]) -> np.ndarray:
    """The hues (0-179) in none of `boxes`."""
    inside = np.zeros(180, bool)
    for lo, hi in boxes:
        inside[lo[0] : hi[0] + 1] = True
    return np.flatnonzero(~inside)


_HUE_ANGLE = np.arange(180) * (2.0 * np.pi / 180.0)
_HUE_COS, _HUE_SIN = np.cos(_HUE_ANGLE), np.sin(_HUE_ANGLE)


def circular_mean_hue(hues: np.ndarray) -> float:
    """Mean of OpenCV hues (integers 0-179, a circle of 180 steps) [hue steps]: red's pixels sit
    on both sides of 0, where an ordinary mean or median lands on the opposite colour."""
    count = np.bincount(hues.ravel(), minlength=180)[:180]  # a histogram, then 180 products
    mean = math.atan2(float(count @ _HUE_SIN), float(count @ _HUE_COS))
    return (mean * 180.0 / (2.0 * math.pi)) % 180.0


def hue_margin(hue: float, boxes: Sequence[HsvBox]) -> float:
    """Distance (hue steps, circular over 180) from `hue` to the nearest hue outside `boxes`."""
    outside = _outside_hues(tuple((tuple(lo), tuple(hi)) for lo, hi in boxes))  # hashable
    if len(outside) == 0:
        return 90.0
    d = np.abs(outside - hue)
    return float(np.min(np.minimum(d, 180 - d)))


def _class_mask(hsv: np.ndarray, boxes: Sequence[HsvBox]) -> np.ndarray:
    """255 where a pixel of `hsv` is in one of `boxes`, else 0. Shape (h, w), uint8."""
    mask = None
    for lo, hi in boxes:
        part = cv2.inRange(hsv, np.array(lo, np.uint8), np.array(hi, np.uint8))
        mask = part if mask is None else cv2.bitwise_or(mask, part, dst=mask)
    assert mask is not None  # a class has at least one box (the scenario checks it)
    return mask


def components(mask: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    """Pixels (rows, cols; row-major order) of each 8-connected component of `mask`, in label
    order. One `cv2.connectedComponents` and a stable sort of the labelled pixels: OpenCV's
    statistics (`connectedComponentsWithStats`) cost 5x the labelling itself."""
    n, labels = cv2.connectedComponents(mask, connectivity=8)
    if n <= 1:
        return []
    rows, cols = np.nonzero(labels)
    if n == 2:
        return [(rows, cols)]
    lab = labels[rows, cols]
    order = np.argsort(lab, kind="stable")
    ends = np.cumsum(np.bincount(lab, minlength=n)[1:])
    rows, cols = rows[order], cols[order]
    return [(rows[a:b], cols[a:b]) for a, b in zip(np.r_[0, ends[:-1]], ends, strict=True)]


def find_blobs(
    rgb: np.ndarray,
    classes: Mapping[str, Sequence[HsvBox]],
    roi: tuple[int, int, int, int] | None = None,
    min_pixels: int = 30,
) -> list[Blob]:
    """Blobs of each colour class in an RGB image.

    Pixels are classified in HSV (`cv2.cvtColor`, `cv2.inRange`), cleaned with a 3x3 opening
    (single noisy pixels go), grouped with `cv2.connectedComponents` (8-connected).

    Args:
        rgb: Image. Shape (height, width, 3), uint8.
        classes: Class name -> its HSV boxes.
        roi: Region of interest `(x0, y0, x1, y1)` [px], end exclusive; None: the whole image.
        min_pixels: Smallest blob kept [px].
    """
    h, w = rgb.shape[:2]
    x0, y0, x1, y1 = roi if roi is not None else (0, 0, w, h)
    x0, y0, x1, y1 = max(0, x0), max(0, y0), min(w, x1), min(h, y1)
    hsv = cv2.cvtColor(np.ascontiguousarray(rgb[y0:y1, x0:x1]), cv2.COLOR_RGB2HSV)
    out: list[Blob] = []
    rh, rw = hsv.shape[:2]
    for name, boxes in classes.items():
        mask = _class_mask(hsv, boxes)
        # work on the part of the image where the class is at all (objects are small)
        cx, cy, cw, ch = cv2.boundingRect(mask)
        if cw == 0:
            continue
        cx0, cy0 = max(0, cx - 1), max(0, cy - 1)
        cx1, cy1 = min(rw, cx + cw + 1), min(rh, cy + ch + 1)
        sub = cv2.morphologyEx(mask[cy0:cy1, cx0:cx1], cv2.MORPH_OPEN, _KERNEL)
        for sub_rows, sub_cols in components(sub):
            if len(sub_rows) < min_pixels:
                continue
            rows, cols = sub_rows + cy0, sub_cols + cx0  # in the region of interest
            by, bh = int(rows[0]), int(rows[-1] - rows[0]) + 1  # rows are in row-major order
            bx = int(cols.min())
            bw = int(cols.max()) - bx + 1
            hue = circular_mean_hue(hsv[rows, cols, 0])
            cut = bx == 0 or by == 0 or bx + bw == rw or by + bh == rh
            out.append(
                Blob(
                    cls=name,
                    rows=rows + y0,
                    cols=cols + x0,
                    bbox=(bx + x0, by + y0, bw, bh),
                    cut=cut,
                    hue_margin=hue_margin(hue, boxes),
                    bounds=(x0, y0, x1, y1),
                )
            )
    return out
