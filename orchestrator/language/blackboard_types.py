"""Blackboard value types: checking declared defaults, overrides and skill writes."""

from __future__ import annotations

import math
from typing import Any

from pydantic import ValidationError

from ..world.pose import Pose

__all__ = ["all_finite", "check_type", "sample_value"]


def all_finite(value: Any) -> bool:
    """No NaN or infinity anywhere in `value` (nested at most `max_depth` deep by the loader)."""
    if isinstance(value, float):
        return math.isfinite(value)
    if isinstance(value, dict):
        return all(all_finite(v) for v in value.values())
    if isinstance(value, list):
        return all(all_finite(v) for v in value)
    return True


def _number(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def check_type(value: Any, type_: str) -> bool:
    """Whether `value` is a valid `type_` value (None means "not set yet" and always passes)."""
    if value is None or type_ == "any":
        return True
    if type_ == "str":
        return isinstance(value, str)
    if type_ == "int":
        return isinstance(value, int) and not isinstance(value, bool)
    if type_ == "float":
        return _number(value)
    if type_ == "bool":
        return isinstance(value, bool)
    if type_ == "vec3":
        return isinstance(value, list) and len(value) == 3 and all(_number(v) for v in value)
    if type_ == "pose":
        if isinstance(value, Pose):
            return True
        try:
            Pose.coerce(value)
        except (ValidationError, TypeError, ValueError):
            return False
        return isinstance(value, dict)
    if type_ == "list":
        return isinstance(value, list)
    if type_ == "dict":
        return isinstance(value, dict)
    return False


_SAMPLES: dict[str, Any] = {
    "str": "x",
    "int": 1,
    "float": 1.0,
    "bool": True,
    "vec3": [0.0, 0.0, 0.0],
    "pose": {"pos": [0.0, 0.0, 0.0], "quat": [1.0, 0.0, 0.0, 0.0]},
    "list": [],
    "dict": {},
}


def sample_value(type_: str) -> Any:
    """A representative value of `type_` for static parameter checks (None for `any`)."""
    return _SAMPLES.get(type_)
