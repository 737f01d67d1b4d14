"""Figures of a free box that several checks measure: its tilt and its extent along world z."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

__all__ = ["tilt_deg", "z_extent"]


def tilt_deg(quat: Sequence[float]) -> float:
    """Angle between a body's z axis and world z [deg], from its quaternion (w, x, y, z)."""
    _, x, y, _ = quat
    return math.degrees(math.acos(max(-1.0, min(1.0, 1.0 - 2.0 * (x * x + y * y)))))


def z_extent(quat: Sequence[float], half_size: Sequence[float] | np.ndarray) -> float:
    """Half the height of a box along world z [m]: its half sizes (box frame, [m]) projected
    through its rotation (quaternion w, x, y, z). Equals `half_size[2]` when it stands upright."""
    w, x, y, z = quat
    row = (2.0 * (x * z - w * y), 2.0 * (y * z + w * x), 1.0 - 2.0 * (x * x + y * y))
    return sum(abs(r) * float(h) for r, h in zip(row, half_size, strict=True))
