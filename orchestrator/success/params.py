"""The parameters of a success check, as a scenario's `success:` entry holds them.

Kept apart from the check classes (base.py), which read the run's `Context`: the scenario
model holds validated parameters and must not depend on the engine.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Annotated, Any

from pydantic import BaseModel, ConfigDict, Field

__all__ = ["CheckParams", "Vec3", "blackboard_fields"]

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


def blackboard_fields(params: type[CheckParams], values: Mapping[str, Any]) -> list[str]:
    """The parameters of an entry given as `$key` (`xy_tol_m: $tolerance`, `object: $object`):
    read from the blackboard when the check runs, and validated then with the value read.
    A `SCENE_TARGET` parameter is not among them: its check follows the `$key` itself (a
    pose the flow wrote is a target as it is)."""
    out = []
    for name, value in values.items():
        info = params.model_fields.get(name)
        if name == "kind" or info is None or not (isinstance(value, str) and value[:1] == "$"):
            continue
        extra = info.json_schema_extra
        if isinstance(extra, dict) and extra.get("scene_ref") == "target":
            continue
        out.append(name)
    return out
