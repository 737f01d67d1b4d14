"""`path_deviation`: the tool tip stays within a distance of the path the active skill planned.

A skill that follows a path publishes it on `ctx.planned_path` while it follows it (the
`contact` skill does while tracing); the guard checks nothing while no path is published.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, ClassVar

from pydantic import Field, PositiveFloat

from .base import Guard, GuardParams, Violation

if TYPE_CHECKING:
    from ..engine.context import Context

__all__ = ["PathDeviation"]


class PathDeviationParams(GuardParams):
    max_m: PositiveFloat = Field(
        default=0.001, description="Largest allowed distance of the TCP from the path [m]."
    )


class PathDeviation(Guard):
    """Fires when the TCP (the tool tip) is farther than `max_m` from the published path."""

    name: ClassVar[str] = "path_deviation"
    Params: ClassVar[type[GuardParams]] = PathDeviationParams

    params: PathDeviationParams

    def bind(self, ctx: Context) -> None:
        self._tcp = ctx.data.site_xpos[ctx.world.tcp_site]  # a view: MjData never reallocates

    def check(self, ctx: Context) -> Violation | None:
        path = ctx.planned_path
        if path is None:
            return None
        dev = path.deviation(self._tcp)
        if dev <= self.params.max_m:
            return None
        return Violation(
            self.name,
            f"tool tip {dev * 1000:.3f} mm from the planned path exceeds "
            f"{self.params.max_m * 1000:.3f} mm",
            round(dev, 7),
            self.params.max_m,
        )

    def monitored(self, ctx: Context) -> tuple[float, float] | None:
        path = ctx.planned_path
        if path is None:
            return None
        return path.deviation(self._tcp), self.params.max_m
