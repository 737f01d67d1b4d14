"""Ground truth for perception: what each detection should have been, and how far off it was.

A detection is matched to the nearest true object (top-face centre, in the table plane); its
errors are the distance between the two top-face centres and the yaw difference modulo the
top face's symmetry (a quarter turn for a square, a half turn for a rectangle).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from .colours import classify_rgb
from .detections import Detection
from .frame import Frame

if TYPE_CHECKING:
    from ..world.world import World

__all__ = [
    "Match",
    "TrueObject",
    "fully_in_view",
    "match_detections",
    "true_objects",
    "yaw_error_deg",
]

MATCH_RADIUS_M = 0.03
"""A detection farther than this (xy) from every true object matches none [m]."""


@dataclass(frozen=True)
class TrueObject:
    """An object as the simulator knows it.

    Attributes:
        name: Scene object name.
        cls: Colour class of its nominal colour (None: in no class).
        top: Centre of its top face in the world [m]. Shape (3,).
        yaw: Heading about the world z axis [rad].
        size: Full edge lengths [m]. Shape (3,).
    """

    name: str
    cls: str | None
    top: np.ndarray
    yaw: float
    size: np.ndarray

    @property
    def symmetry(self) -> float:
        """Turn [rad] that leaves its top face unchanged."""
        sx, sy = float(self.size[0]), float(self.size[1])
        return math.pi / 2 if abs(sx - sy) < 1e-6 else math.pi

    def corners(self) -> np.ndarray:
        """Its eight corners in the world [m] (upright box). Shape (8, 3)."""
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        hx, hy, hz = (float(v) / 2 for v in self.size)
        out = []
        for x in (-hx, hx):
            for y in (-hy, hy):
                for z in (-2 * hz, 0.0):
                    out.append([c * x - s * y, s * x + c * y, z])
        return np.array(out) + self.top


@dataclass(frozen=True)
class Match:
    """A detection and the true object it matched (None: a detection of nothing)."""

    detection: Detection
    truth: TrueObject | None

    @property
    def correct(self) -> bool:
        """It matched an object of its own class."""
        return self.truth is not None and self.truth.cls == self.detection.cls

    @property
    def position_error_m(self) -> float:
        """Distance between its position and the true top-face centre [m] (NaN: no match)."""
        if self.truth is None:
            return math.nan
        return float(np.linalg.norm(self.detection.pos - self.truth.top))

    @property
    def yaw_error_deg(self) -> float:
        """Yaw error modulo the top face's symmetry [deg] (NaN: no match)."""
        if self.truth is None:
            return math.nan
        return yaw_error_deg(self.detection.yaw, self.truth.yaw, self.truth.symmetry)


def yaw_error_deg(measured: float, true: float, period: float) -> float:
    """|measured - true| modulo `period` [rad], folded into [0, period / 2], in degrees."""
    d = math.fmod(measured - true, period)
    d = abs(d)
    return math.degrees(min(d, period - d))


def match_detections(detections: list[Detection], truths: list[TrueObject]) -> list[Match]:
    """Each detection with the true object nearest to it in xy (within `MATCH_RADIUS_M`)."""
    out = []
    tops = np.array([t.top[:2] for t in truths]).reshape(-1, 2)
    for det in detections:
        best = None
        if len(truths):
            dist = np.linalg.norm(tops - det.pos[:2], axis=1)
            i = int(np.argmin(dist))
            best = truths[i] if dist[i] <= MATCH_RADIUS_M else None
        out.append(Match(det, best))
    return out


def fully_in_view(truth: TrueObject, frame: Frame, margin_px: float = 2.0) -> bool:
    """All eight corners of the object project inside the image, `margin_px` from its border,
    and the camera sees its top-face centre (no other surface in front of it)."""
    k = frame.intrinsics
    uv = frame.project(truth.corners())
    if not np.all(np.isfinite(uv)):
        return False
    inside = (uv[:, 0] >= margin_px) & (uv[:, 0] <= k.width - margin_px)
    inside &= (uv[:, 1] >= margin_px) & (uv[:, 1] <= k.height - margin_px)
    if not np.all(inside):
        return False
    u, v = frame.project(truth.top[None])[0]
    row, col = int(v), int(u)
    local = (truth.top - frame.pos) @ frame.rot
    depth = float(frame.depth[row, col])
    return depth > 0.0 and abs(depth - (-local[2])) < 0.005


def true_objects(world: World) -> list[TrueObject]:
    """The scene's free objects as the simulator holds them now (their class: a parcel's true
    class, else the colour class of their nominal colour, before any jitter; their size: the
    one they have now — a conveyor's recycled bodies change it)."""
    classes = world.scenario.perception.class_boxes()
    qpos = world.data.qpos
    out = []
    for spec in world.scenario.scene.objects:
        handle = world.objects[spec.name]
        adr = handle.qpos_adr
        pos = qpos[adr : adr + 3]
        w, x, y, z = (float(v) for v in qpos[adr + 3 : adr + 7])
        normal = np.array([2 * (x * z + w * y), 2 * (y * z - w * x), 1 - 2 * (x * x + y * y)])
        out.append(
            TrueObject(
                name=spec.name,
                cls=world.parcel_classes.get(spec.name) or classify_rgb(spec.rgba, classes),
                top=pos + normal * float(handle.half_size[2]),
                yaw=math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z)),
                size=2.0 * handle.half_size,
            )
        )
    return out
