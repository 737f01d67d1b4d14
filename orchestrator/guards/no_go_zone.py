"""`no_go_zone`: no robot or tool geom enters a forbidden box (a critical structure).

The zones are the scenario's `scene.zones`: boxes drawn in the scene without collision. Every
physics step the guard culls the robot's geoms by their bounding spheres against each zone box
(a few array operations), then asks MuJoCo for the exact distance of the few left
(`mj_geomDistance`: convex hulls for meshes).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, ClassVar

import numpy as np
from pydantic import Field, NonNegativeFloat

from ..exceptions import OrchestratorError
from ..world.indexing import as_index
from .base import Guard, GuardParams, Violation

if TYPE_CHECKING:
    from ..engine.context import Context

__all__ = ["NoGoZone", "UnknownZoneError"]


class UnknownZoneError(OrchestratorError):
    """A `no_go_zone` guard names a zone the scenario does not have."""


class NoGoZoneParams(GuardParams):
    zones: list[str] | None = Field(
        default=None,
        description="Zones to watch, by name (default: every zone of the scene).",
        json_schema_extra={"scene_ref": "zone"},
    )
    margin_m: NonNegativeFloat = Field(
        default=0.0, description="Fire when a geom comes closer to a zone than this [m]."
    )


class NoGoZone(Guard):
    """Fires when any robot or tool geom comes within `margin_m` of (or into) a no-go zone."""

    name: ClassVar[str] = "no_go_zone"
    Params: ClassVar[type[GuardParams]] = NoGoZoneParams
    priority: ClassVar[int] = 1
    ease_tolerance: ClassVar[float] = 0.001
    ease_unit: ClassVar[str] = "m"

    params: NoGoZoneParams

    def bind(self, ctx: Context) -> None:
        import mujoco  # here, not at the top: validation reads the Params without MuJoCo

        self._geom_distance = mujoco.mj_geomDistance
        m, d, w = ctx.model, ctx.data, ctx.world
        names = self.params.zones if self.params.zones is not None else list(w.zones)
        unknown = [n for n in names if n not in w.zones]
        if unknown:
            raise UnknownZoneError(
                f"no_go_zone: no zone {', '.join(map(repr, unknown))} in the scene "
                f"(valid: {', '.join(sorted(w.zones)) or 'none: add scene.zones'})"
            )
        margin = self.params.margin_m
        self.zone_names = names
        self.zone_geoms = [w.zones[n] for n in names]
        # zones hang on fixed bodies (the world, the phantom): their poses never change
        self.zones = [
            (d.geom_xpos[g].copy(), d.geom_xmat[g].reshape(3, 3).copy(), m.geom_size[g].copy())
            for g in self.zone_geoms
        ]
        geoms = np.array(sorted(w.robot_geoms), dtype=int)
        self.geoms = geoms
        self.radius = m.geom_rbound[geoms] + margin
        self.sphere_sq = [
            (self.radius + float(np.linalg.norm(half))) ** 2 for _, _, half in self.zones
        ]
        index = as_index(geoms)
        # a view bound once (MjData never reallocates) when the robot's geoms are contiguous
        self._centres = d.geom_xpos[index] if isinstance(index, slice) else None
        self._fromto = np.zeros(6)

    def _nearest(self, ctx: Context) -> tuple[float, int, int] | None:
        """(distance [m], robot geom, zone index) of the closest pair the cull lets through.

        Cull: bounding spheres of the robot's geoms against each zone's bounding sphere, then
        against the zone box itself; the exact distance only for what is left.
        """
        centres = self._centres if self._centres is not None else ctx.data.geom_xpos[self.geoms]
        best: tuple[float, int, int] | None = None
        for k, (zc, rot, half) in enumerate(self.zones):
            rel = centres - zc
            near = np.einsum("ij,ij->i", rel, rel) < self.sphere_sq[k]
            if not near.any():
                continue
            local = np.abs(rel[near] @ rot) - half
            gap = np.linalg.norm(np.maximum(local, 0.0), axis=1)
            for g in self.geoms[near][gap < self.radius[near]]:
                limit = self.params.margin_m + 0.01
                dist = self._geom_distance(
                    ctx.model, ctx.data, int(g), self.zone_geoms[k], limit, self._fromto
                )
                if best is None or dist < best[0]:
                    best = (float(dist), int(g), k)
        return best

    def check(self, ctx: Context) -> Violation | None:
        hit = self._nearest(ctx)
        if hit is None or hit[0] > self.params.margin_m:
            return None
        dist, geom, k = hit
        m = ctx.model
        part = m.geom(geom).name or m.body(int(m.geom_bodyid[geom])).name
        where = "inside" if dist <= 0.0 else f"{dist * 1000:.1f} mm from"
        return Violation(
            self.name,
            f"{part} is {where} no-go zone {self.zone_names[k]!r}",
            {"zone": self.zone_names[k], "geom": part, "distance_m": round(dist, 6)},
            self.params.margin_m,
        )

    def monitored(self, ctx: Context) -> tuple[float, float] | None:
        hit = self._nearest(ctx)
        return (hit[0], self.params.margin_m) if hit is not None else None

    def excess(self, ctx: Context) -> np.ndarray:
        """How far the nearest robot geom is inside the margin of a zone [m] (-1 when none is
        near). Shape (1,)."""
        hit = self._nearest(ctx)
        return np.array([-1.0 if hit is None else self.params.margin_m - hit[0]])
