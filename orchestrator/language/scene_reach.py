"""Objects, markers and a pick area of a table-top cell: on the table, within the arm's reach.

`orchestrator explore` found pick_place accepting a cube whose randomization range reached
10 m (it started in the air beside the table, fell to the floor and the flow ended `lost`) and
a pad 9.4 m away (the flow ended `unreachable`), and sorting a pick area 6.5 m off (its
parcels fell to the floor): every value was inside the schema's bounds.
So every free object that starts on the table (no `spots`) and every marker is checked over
its whole randomization range: its centre on the table top, and (for a fixed-base arm) within
the arm's reach of its shoulder at the table's height; a pick area of parcels on the table top
(a parcel out of reach is the sorting flow's to reject with its reason). Both regions are
convex, so the range's corners decide.
"""

from __future__ import annotations

import numpy as np

from ..robots import ROBOTS
from .diagnostics import Diagnostic
from .scenario import Scenario
from .yamlio import SourceMap

__all__ = ["check_scene_reach"]


def _corners(xy: list[float], x: list[float], y: list[float]) -> list[tuple[float, float]]:
    return [(xy[0] + dx, xy[1] + dy) for dx in (x[0], x[1]) for dy in (y[0], y[1])]


def check_scene_reach(scenario: Scenario, source: SourceMap) -> list[Diagnostic]:
    """Every table-top object (with its randomization) and marker lies on the table top and
    within the arm's reach (see the module docstring)."""
    scene = scenario.scene
    table = scene.table
    lo = np.asarray(table.center_xy) - np.asarray(table.size_xy) / 2.0
    hi = np.asarray(table.center_xy) + np.asarray(table.size_xy) / 2.0
    cls = ROBOTS.get(scenario.robot.name)
    shoulder = None
    if cls is not None and not cls.base_joints:  # a mobile base drives to what it picks
        shoulder = cls().shoulder(
            np.zeros(len(cls.arm_joints)), np.asarray(scenario.robot.base_pos)
        )
    items = []
    for i, obj in enumerate(scene.objects):
        if not obj.randomize.spots:
            r = obj.randomize
            items.append((("scene", "objects", i), obj.name, _corners(obj.xy, r.x, r.y),
                          "`xy` and `randomize.x`/`randomize.y`", True))  # fmt: skip
    parcels = scene.parcels
    if parcels is not None:  # explore on sorting: a pick area 6.5 m off, its parcels fell
        # (on the table only: a parcel out of reach is the sorting flow's to reject, with its
        # reason, docs/sorting.md)
        half = [parcels.area_size_xy[0] / 2.0, parcels.area_size_xy[1] / 2.0]
        items.append((("scene", "parcels"), "the pick area",
                      _corners(parcels.area_center_xy, [-half[0], half[0]], [-half[1], half[1]]),
                      "`area_center_xy` and `area_size_xy`", False))  # fmt: skip
    for i, marker in enumerate(scene.markers):
        items.append((("scene", "markers", i), marker.name, [tuple(marker.xy)], "`xy`", True))
    out = []
    for at, name, corners, keys, reach in items:
        off = [c for c in corners if not (lo[0] <= c[0] <= hi[0] and lo[1] <= c[1] <= hi[1])]
        if off:
            out.append(source.diag(at, (
                f"{name} can be at [{off[0][0]:g}, {off[0][1]:g}], off the table top "
                f"(x {lo[0]:g} .. {hi[0]:g}, y {lo[1]:g} .. {hi[1]:g} m): it would not rest on "
                f"the table; narrow its {keys}")))  # fmt: skip
            continue
        if shoulder is None or not reach:
            continue
        points = [np.array([c[0], c[1], table.height]) for c in corners]
        far = max(points, key=lambda p: float(np.linalg.norm(p - shoulder)))
        dist = float(np.linalg.norm(far - shoulder))
        if dist > cls.reach_m:  # type: ignore[union-attr]
            out.append(source.diag(at, (
                f"{name} can be at [{far[0]:g}, {far[1]:g}] on the table, {dist:.3f} m from the "
                f"{scenario.robot.name}'s shoulder, beyond its reach ({cls.reach_m} m): "  # type: ignore[union-attr]
                f"narrow its {keys}")))  # fmt: skip
    return out
