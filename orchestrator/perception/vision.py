"""Colour segmentation with OpenCV: pixels of each colour class, grouped into blobs."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import cv2
import numpy as np

from .colours import HsvBox

__all__ = ["Blob", "circular_mean_hue", "find_blobs", "hue_margin"]

_KERNEL = np.ones((3, 3), np.uint8)


@dataclass(frozen=True)
class Blob:
    """A connected region of one colour class in an image.

    Attributes:
        cls: Colour class name.
        rows: Row of each pixel. Shape (n,).
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


def _class_hues(boxes: Sequence[HsvBox]) -> np.ndarray:
    hues = np.zeros(180, bool)
    for lo, hi in boxes:
        hues[lo[0] : hi[0] + 1] = True
    return hues


def circular_mean_hue(hues: np.ndarray) -> float:
    """Mean of OpenCV hues (0-179, a circle of 180 steps) [hue steps]: red's pixels sit on both
    sides of 0, where an ordinary mean or median lands on the opposite colour."""
    angle = hues.astype(np.float64) * (2.0 * np.pi / 180.0)
    mean = np.arctan2(np.mean(np.sin(angle)), np.mean(np.cos(angle)))
    return float(mean * 180.0 / (2.0 * np.pi)) % 180.0


def hue_margin(hue: float, boxes: Sequence[HsvBox]) -> float:
    """Distance (hue steps, circular over 180) from `hue` to the nearest hue outside `boxes`."""
    inside = _class_hues(boxes)
    outside = np.flatnonzero(~inside)
    if len(outside) == 0:
        return 90.0
    d = np.abs(outside - hue)
    return float(np.min(np.minimum(d, 180 - d)))


def find_blobs(
    rgb: np.ndarray,
    classes: Mapping[str, Sequence[HsvBox]],
    roi: tuple[int, int, int, int] | None = None,
    min_pixels: int = 30,
) -> list[Blob]:
    """Blobs of each colour class in an RGB image.

    Pixels are classified in HSV (`cv2.cvtColor`, `cv2.inRange`), cleaned with a 3x3 opening
    (single noisy pixels go), grouped with `cv2.connectedComponentsWithStats` (8-connected).

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
        mask = np.zeros((rh, rw), np.uint8)
        for lo, hi in boxes:
            mask |= cv2.inRange(hsv, np.array(lo, np.uint8), np.array(hi, np.uint8))
        # work on the part of the image where the class is at all (objects are small)
        cx, cy, cw, ch = cv2.boundingRect(mask)
        if cw == 0:
            continue
        cx0, cy0 = max(0, cx - 1), max(0, cy - 1)
        cx1, cy1 = min(rw, cx + cw + 1), min(rh, cy + ch + 1)
        sub = cv2.morphologyEx(mask[cy0:cy1, cx0:cx1], cv2.MORPH_OPEN, _KERNEL)
        n, labels, stats, _ = cv2.connectedComponentsWithStats(sub, connectivity=8)
        for i in range(1, n):
            bx, by, bw, bh, area = (int(v) for v in stats[i])
            if area < min_pixels:
                continue
            rows, cols = np.nonzero(labels[by : by + bh, bx : bx + bw] == i)
            bx, by = bx + cx0, by + cy0  # in the region of interest
            rows, cols = rows + by, cols + bx
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
