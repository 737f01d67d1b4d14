"""What a skill or a success check holds as plain data: the state a snapshot records for it.

A value is *plain data* when it is a number, a string, a bool, None, a numpy array of numbers,
a pydantic model (recorded as its dump) or a list, tuple or dict (string keys) of plain data.
`Skill.snapshot_state` and `SuccessCheck.snapshot_state` default to `plain_state(self)`.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from pydantic import BaseModel

__all__ = ["attributes", "is_data", "plain_state"]

_MAX_DEPTH = 12


def is_data(value: Any, depth: int = 0) -> bool:
    """`value` is plain data (see the module docstring)."""
    if depth > _MAX_DEPTH:
        return False
    if isinstance(value, (bool, int, float, str, type(None), np.number, np.bool_, BaseModel)):
        return True
    if isinstance(value, np.ndarray):
        return not value.dtype.hasobject
    if isinstance(value, (list, tuple)):
        return all(is_data(v, depth + 1) for v in value)
    if isinstance(value, dict):
        return all(isinstance(k, str) and is_data(v, depth + 1) for k, v in value.items())
    return False


def attributes(obj: Any) -> dict[str, Any]:
    """`obj`'s attributes by name: its `__dict__`, and its `__slots__` that are set."""
    out = dict(getattr(obj, "__dict__", {}))
    for cls in type(obj).__mro__:
        slots = cls.__dict__.get("__slots__", ())
        for name in (slots,) if isinstance(slots, str) else slots:
            if name not in ("__dict__", "__weakref__") and hasattr(obj, name):
                out[name] = getattr(obj, name)
    return out


def plain_state(obj: Any) -> dict[str, Any]:
    """Every attribute of `obj` that is plain data, by name, in name order."""
    return {k: v for k, v in sorted(attributes(obj).items()) if is_data(v)}
