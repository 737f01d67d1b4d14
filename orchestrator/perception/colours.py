"""Colour classes: named colours and explicit ranges in OpenCV's HSV space.

OpenCV's 8-bit HSV: hue H in [0, 180) (degrees / 2), saturation S and value V in [0, 255].
A class is a union of HSV boxes (red needs two: its hue wraps around 0).
"""

from __future__ import annotations

import colorsys
from collections.abc import Mapping, Sequence

import numpy as np

__all__ = ["NAMED_COLOURS", "HsvBox", "classify_rgb", "hsv_boxes"]

HsvBox = tuple[tuple[int, int, int], tuple[int, int, int]]
"""An inclusive HSV box `((h_lo, s_lo, v_lo), (h_hi, s_hi, v_hi))`, OpenCV 8-bit units."""

_S_MIN, _V_MIN = 110, 50
"""Saturation and value below which a pixel is grey, white or black: never a colour class."""

NAMED_COLOURS: dict[str, tuple[HsvBox, ...]] = {
    "red": (((0, _S_MIN, _V_MIN), (8, 255, 255)), ((170, _S_MIN, _V_MIN), (179, 255, 255))),
    "orange": (((11, _S_MIN, _V_MIN), (19, 255, 255)),),
    "yellow": (((21, _S_MIN, _V_MIN), (36, 255, 255)),),
    "green": (((42, _S_MIN, _V_MIN), (85, 255, 255)),),
    "cyan": (((88, _S_MIN, _V_MIN), (99, 255, 255)),),
    "blue": (((102, _S_MIN, _V_MIN), (130, 255, 255)),),
    "purple": (((133, _S_MIN, _V_MIN), (150, 255, 255)),),
    "magenta": (((152, _S_MIN, _V_MIN), (167, 255, 255)),),
}
"""Named colours -> their HSV boxes. Neighbours leave a gap of 2-3 hue steps between them,
so that no pixel belongs to two named classes."""


def hsv_boxes(spec: str | Sequence[Sequence[Sequence[float]]]) -> tuple[HsvBox, ...]:
    """The HSV boxes of a class given as a colour name or as a list of `[lo, hi]` boxes.

    Raises:
        ValueError: An unknown colour name (the message lists the valid ones).
    """
    if isinstance(spec, str):
        try:
            return NAMED_COLOURS[spec]
        except KeyError:
            raise ValueError(
                f"unknown colour {spec!r} (valid: {', '.join(NAMED_COLOURS)})"
            ) from None
    out = []
    for lo, hi in spec:
        out.append((_triple(lo), _triple(hi)))
    return tuple(out)


def _triple(v: Sequence[float]) -> tuple[int, int, int]:
    return (int(v[0]), int(v[1]), int(v[2]))


def classify_rgb(rgb: Sequence[float], classes: Mapping[str, Sequence[HsvBox]]) -> str | None:
    """The class whose boxes hold an RGB colour (components in [0, 1]); None if none does.

    This is how the true class of a scene object is known: by its nominal colour.
    """
    h, s, v = colorsys.rgb_to_hsv(*(float(c) for c in rgb[:3]))
    hsv = np.array([round(h * 180.0) % 180, round(s * 255.0), round(v * 255.0)])
    for name, boxes in classes.items():
        for lo, hi in boxes:
            if np.all(hsv >= lo) and np.all(hsv <= hi):
                return name
    return None
