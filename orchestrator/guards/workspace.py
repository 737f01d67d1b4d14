"""`workspace`: the TCP stays inside an axis-aligned box."""

from __future__ import annotations

from typing import TYPE_CHECKING, Annotated, ClassVar

import numpy as np
from pydantic import Field, model_validator

from .base import Envelope, Guard, GuardParams, Violation

if TYPE_CHECKING:
    from ..engine.context import Context

__all__ = ["Workspace"]

Vec3 = Annotated[list[float], Field(min_length=3, max_length=3)]


class WorkspaceParams(GuardParams):
    min: Vec3 = Field(default_factory=lambda: [-1.0, -1.0, 0.0], description="Lower corner [m].")
    max: Vec3 = Field(default_factory=lambda: [1.0, 1.0, 1.5], description="Upper corner [m].")

    @model_validator(mode="after")
    def _ordered(self) -> WorkspaceParams:
        for axis, lo, hi in zip("xyz", self.min, self.max, strict=True):
            if lo >= hi:
                raise ValueError(f"min.{axis} = {lo} must be below max.{axis} = {hi}")
        return self


class Workspace(Guard):
    """Fires when the TCP leaves the box [min, max] (world frame)."""

    name: ClassVar[str] = "workspace"
    Params: ClassVar[type[GuardParams]] = WorkspaceParams
    ease_tolerance: ClassVar[float] = 0.001
    ease_unit: ClassVar[str] = "m"

    params: WorkspaceParams

    def bind(self, ctx: Context) -> None:
        self.lo = np.asarray(self.params.min, float)
        self.hi = np.asarray(self.params.max, float)
        self.site = ctx.world.tcp_site
        # check() runs every physics step: a view bound once (MjData never reallocates) and
        # plain floats cost a fraction of a few small numpy operations.
        self._tcp = ctx.data.site_xpos[self.site]
        self._x_lo, self._y_lo, self._z_lo = self.params.min
        self._x_hi, self._y_hi, self._z_hi = self.params.max

    def check(self, ctx: Context) -> Violation | None:
        x, y, z = self._tcp.tolist()
        if not (
            x < self._x_lo
            or x > self._x_hi
            or y < self._y_lo
            or y > self._y_hi
            or z < self._z_lo
            or z > self._z_hi
        ):  # NaN compares false: divergence is the runner's to report, not a violation
            return None
        p = ctx.data.site_xpos[self.site]
        i = int(np.argmax(np.maximum(self.lo - p, p - self.hi)))
        bound = self.lo[i] if p[i] < self.lo[i] else self.hi[i]
        axis = "xyz"[i]
        return Violation(
            self.name,
            f"TCP {axis} = {p[i]:.4f} m is outside the workspace "
            f"[{self.lo[i]:.3f}, {self.hi[i]:.3f}]",
            [round(float(v), 6) for v in p],
            {"axis": axis, "bound": round(float(bound), 6)},
        )

    def envelope(self, ctx: Context) -> Envelope:
        return Envelope(bounds=((self._tcp, self.params.min, self.params.max),))

    def monitored(self, ctx: Context) -> tuple[float, float]:
        p = ctx.data.site_xpos[self.site]
        return float(np.min(np.minimum(p - self.lo, self.hi - p))), 0.0

    def excess(self, ctx: Context) -> np.ndarray:
        """How far the TCP is below `min` and above `max`, per axis [m]. Shape (6,)."""
        p = ctx.data.site_xpos[self.site]
        return np.concatenate([self.lo - p, p - self.hi])
