"""The parameters of a success check, as a scenario's `success:` entry holds them.

Kept apart from the check classes (base.py), which read the run's `Context`: the scenario
model holds validated parameters and must not depend on the engine.
"""

from __future__ import annotations

from typing import Annotated

from pydantic import BaseModel, ConfigDict, Field

__all__ = ["CheckParams", "Vec3"]

Vec3 = Annotated[
    list[Annotated[float, Field(ge=-10.0, le=10.0)]], Field(min_length=3, max_length=3)
]
"""A point in the world frame [m] (each coordinate within 10 m)."""


class CheckParams(BaseModel):
    """Base of every check's `Params`: the entry's `kind` plus the check's own keys; unknown
    keys are an error. A field with `json_schema_extra=SCENE_OBJECT` names a scene object
    (checked against the scenario before the run), `SCENE_TARGET` an object or a marker (or
    `$key`, followed on the blackboard)."""

    # the validator is built on first use: a command loads every check's Params and uses few
    model_config = ConfigDict(defer_build=True, extra="forbid", allow_inf_nan=False)

    kind: str = Field(description="Which check: its registered `kind`.")
