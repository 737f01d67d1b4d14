"""`no_go_zone`: no robot or tool geom enters a forbidden box (a critical structure).

The zones are the scenario's `scene.zones`: boxes drawn in the scene without collision. Every
physics step the guard culls the robot's geoms by their bounding spheres against each zone box
(a few array operations), then asks MuJoCo for the exact distance of the few left
(`mj_geomDistance`: convex hulls for meshes).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, ClassVar

import mujoco
import numpy as np
from pydantic import Field, NonNegativeFloat

from ..exceptions import OrchestratorError
from ..guard import Guard, GuardParams, Violation

if TYPE_CHECKING:
    from ..context import Context

__all__ = ["NoGoZone", "UnknownZoneError"]


class UnknownZoneError(OrchestratorError):
    """A `no_go_zone` guard names a zone the scenario does not have."""


class NoGoZoneParams(GuardParams):
    zones: list[str] | None = Field(
        default=None, description="Zones to watch, by name (default: every zone of the scene)."
    )
    margin_m: NonNegativeFloat = Field(
        default=0.0, description="Fire when a geom comes closer to a zone than this [m]."
    )


class NoGoZone(Guard):
    """Fires when any robot or tool geom comes within `margin_m` of (or into) a no-go zone."""

    name: ClassVar[str] = "no_go_zone"
    Params: ClassVar[type[GuardParams]] = NoGoZoneParams
    priority: ClassVar[int] = 1

    params: NoGoZoneParams

    def bind(self, ctx: Context) -> None:
        m, w = ctx.model, ctx.world
        names = self.params.zones if self.params.zones is not None else list(w.zones)
        unknown = [n for n in names if n not in w.zones]
        if unknown:
            raise UnknownZoneError(
                f"no_go_zone: no zone {', '.join(map(repr, unknown))} in the scene "
                f"(valid: {', '.join(sorted(w.zones)) or 'none: add scene.zones'})"
            )
        self.zone_names = names
        self.zone_geoms = [w.zones[n] for n in names]
        self.half = [m.geom_size[g].copy() for g in self.zone_geoms]
        self.geoms = np.array(sorted(w.robot_geoms), dtype=int)
        self.radius = m.geom_rbound[self.geoms] + self.params.margin_m
        self._fromto = np.zeros(6)

    def _nearest(self, ctx: Context) -> tuple[float, int, int] | None:
        """(distance [m], robot geom, zone index) of the closest pair the cull lets through."""
        d = ctx.data
        centres = d.geom_xpos[self.geoms]
        best: tuple[float, int, int] | None = None
        for k, zg in enumerate(self.zone_geoms):
            rot = d.geom_xmat[zg].reshape(3, 3)
            local = np.abs((centres - d.geom_xpos[zg]) @ rot) - self.half[k]
            gap = np.linalg.norm(np.maximum(local, 0.0), axis=1)
            for g in self.geoms[gap < self.radius]:
                limit = self.params.margin_m + 0.01
                dist = mujoco.mj_geomDistance(ctx.model, d, int(g), zg, limit, self._fromto)
                if best is None or dist < best[0]:
                    best = (float(dist), int(g), k)
        return best

    def check(self, ctx: Context) -> Violation | None:
        hit = self._nearest(ctx)
        if hit is None or hit[0] > self.params.margin_m:
            return None
        dist, geom, k = hit
        geom_name = ctx.model.geom(geom).name or f"geom {geom}"
        where = "inside" if dist <= 0.0 else f"{dist * 1000:.1f} mm from"
        return Violation(
            self.name,
            f"{geom_name} is {where} no-go zone {self.zone_names[k]!r}",
            {"zone": self.zone_names[k], "geom": geom_name, "distance_m": round(dist, 6)},
            self.params.margin_m,
        )

    def monitored(self, ctx: Context) -> tuple[float, float] | None:
        hit = self._nearest(ctx)
        return (hit[0], self.params.margin_m) if hit is not None else None
