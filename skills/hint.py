"""Position hints: "pick the one *there*" — what a perception skill reports is the object or
detection nearest a point, and nothing if nothing is near it."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Annotated

from pydantic import Field

__all__ = ["POSITION_HINT", "Hint", "HintRadius", "hint_distance"]

POSITION_HINT = {"pose_role": "hint", "radius": "near_radius_m"}
"""`json_schema_extra` of a position hint: the live guardrail checks it (finite, inside the
workspace, an object within `near_radius_m` of it) before anything moves."""

Hint = Annotated[
    list[float] | None,
    Field(
        min_length=3,
        max_length=3,
        description="Position hint `[x, y, z]` in the world [m]: report only what lies within "
        "`near_radius_m` of it in the horizontal plane, the nearest first (null: anywhere).",
        json_schema_extra=POSITION_HINT,
    ),
]
HintRadius = Annotated[
    float,
    Field(gt=0.0, le=1.0, description="How far from the hint, horizontally, a find may be [m]."),
]


def hint_distance(hint: Sequence[float], pos: Sequence[float]) -> float:
    """Horizontal distance of `pos` from the hint [m] (z does not count: a hint on the table
    top names the object standing there)."""
    return math.hypot(pos[0] - hint[0], pos[1] - hint[1])
