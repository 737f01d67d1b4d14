"""`in_region`: an object lies inside a box of the world (a bin, a tray, a shelf)."""

from __future__ import annotations

import itertools
from typing import TYPE_CHECKING, ClassVar

import numpy as np
from pydantic import Field, model_validator

from ..world.pose import Pose
from .base import SCENE_OBJECT, CheckParams, SuccessCheck, Vec3, Verdict

if TYPE_CHECKING:
    from ..engine.context import Context

__all__ = ["InRegion"]

_AXES = "xyz"


class InRegionParams(CheckParams):
    object: str = Field(description="The scene object judged.", json_schema_extra=SCENE_OBJECT)
    min: Vec3 = Field(description="Lower corner of the region, world frame [m].")
    max: Vec3 = Field(description="Upper corner of the region, world frame [m].")
    whole: bool = Field(
        default=False,
        description="Every corner of the object's box inside the region, not only its centre.",
    )

    @model_validator(mode="after")
    def _ordered(self) -> InRegionParams:
        for axis, lo, hi in zip(_AXES, self.min, self.max, strict=True):
            if lo >= hi:
                raise ValueError(f"min {axis} {lo} is not below max {axis} {hi}")
        return self


def _box_corners(pose: Pose, half_size: np.ndarray) -> np.ndarray:
    """The 8 corners of a box at `pose` with `half_size` [m], world frame. Shape (8, 3)."""
    w, x, y, z = pose.quat
    rot = np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )
    signs = np.array(list(itertools.product((-1.0, 1.0), repeat=3)))
    return np.asarray(pose.pos) + (signs * np.asarray(half_size)) @ rot.T


class InRegion(SuccessCheck):
    """The object's centre (with `whole`, every corner of its box) lies inside the box of the
    world from `min` to `max`. A failure says along which axis and by how much it is out.
    Metric: `<name>_outside_mm`, the largest distance of a judged point outside the box
    (0 inside)."""

    kind: ClassVar[str] = "in_region"
    Params: ClassVar[type[CheckParams]] = InRegionParams
    params: InRegionParams

    def _outside(self, ctx: Context) -> tuple[np.ndarray, np.ndarray]:
        """(the judged points, shape (k, 3); how far each is out along each axis [m])."""
        p = self.params
        pose = ctx.object_pose(p.object)
        points = (
            _box_corners(pose, ctx.object_handle(p.object).half_size)
            if p.whole
            else np.asarray([pose.pos])
        )
        lo, hi = np.asarray(p.min), np.asarray(p.max)
        return points, np.maximum(lo - points, 0.0) + np.maximum(points - hi, 0.0)

    def evaluate(self, ctx: Context) -> Verdict:
        p = self.params
        points, out = self._outside(ctx)
        what = "every corner of" if p.whole else "the centre of"
        centre = np.round(np.asarray(ctx.object_pose(p.object).pos), 3).tolist()
        box = f"the box {p.min}..{p.max}"
        if not out.any():
            return Verdict(True, f"{what} {p.object} inside {box} (centre at {centre})")
        worst = np.unravel_index(int(np.argmax(out)), out.shape)
        axis, mm = _AXES[int(worst[1])], float(out[worst]) * 1000.0
        return Verdict(
            False,
            f"{what} {p.object} is {mm:.1f} mm out of {box} along {axis} (centre at {centre})",
        )

    def metrics(self, ctx: Context) -> dict[str, float]:
        _, out = self._outside(ctx)
        return {"outside_mm": round(float(out.max()) * 1000.0, 3)}
