"""What a skill or a success check holds as plain data: the state a snapshot records for it.

A value is *plain data* when it is a number, a string, a bool, None, a numpy array of numbers,
a pydantic model (recorded as its dump) or a list, tuple or dict (string or integer keys) of
plain data.
`Skill.snapshot_state` and `SuccessCheck.snapshot_state` default to `plain_state(self)`, and
their `restore_state(data)` to `restore_plain(self, data)`.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from pydantic import BaseModel

__all__ = ["attributes", "holds_view", "is_data", "plain_state", "restore_plain"]

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
        return all(
            (isinstance(k, str) or (isinstance(k, int) and not isinstance(k, bool)))
            and is_data(v, depth + 1)
            for k, v in value.items()
        )
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


def holds_view(value: Any, depth: int = 0) -> bool:
    """`value` is, or holds, an array that is a view of other memory (MjData's, an array of
    its owner's): such a value is how its owner reads that memory, not state of its own."""
    if isinstance(value, np.ndarray):
        return value.base is not None
    if depth < _MAX_DEPTH and isinstance(value, (list, tuple)):
        return any(holds_view(v, depth + 1) for v in value)
    if depth < _MAX_DEPTH and isinstance(value, dict):
        return any(holds_view(v, depth + 1) for v in value.values())
    return False


def restore_plain(obj: Any, data: dict[str, Any]) -> None:
    """Put back on `obj` what `plain_state` recorded: an array into the array already there
    (`np.copyto`: views of it stay views), a named tuple as its type, anything else set. A
    pydantic model (configuration: the parameters it was made with) is left as it is.

    Raises:
        ValueError: `data` is not a mapping of attribute names.
    """
    if not isinstance(data, dict) or not all(isinstance(k, str) for k in data):
        raise ValueError(f"the state of {type(obj).__name__} is not a mapping of names")
    own = attributes(obj)
    for key, value in data.items():
        now = own.get(key)
        if isinstance(now, BaseModel):
            continue  # configuration
        if isinstance(now, np.ndarray):
            if now.base is not None or not now.flags.writeable:
                continue  # a view of memory restored where it lives; a constant
            if (
                isinstance(value, np.ndarray)
                and value.shape == now.shape
                and (value.dtype == now.dtype)
            ):
                np.copyto(now, value)
                continue
        if _fill(now, value):
            continue  # a dict of arrays filled in place: whatever holds the arrays sees them
        new = _own(value)
        if isinstance(now, tuple) and hasattr(now, "_fields") and isinstance(new, tuple):
            new = type(now)(*new)
        setattr(obj, key, new)


def _fill(now: Any, value: Any) -> bool:
    """Copy a recorded dict of arrays into `now`, a dict of arrays of the same names, shapes
    and types; False (nothing done) for anything else."""
    if not (isinstance(now, dict) and isinstance(value, dict) and now.keys() == value.keys()):
        return False
    pairs = list(zip(now.values(), value.values(), strict=True))
    if not pairs or not all(
        isinstance(a, np.ndarray) and isinstance(b, np.ndarray) and a.shape == b.shape
        and a.dtype == b.dtype and a.base is None and a.flags.writeable
        for a, b in pairs
    ):  # fmt: skip
        return False
    for a, b in pairs:
        np.copyto(a, b)
    return True


def _own(value: Any, depth: int = 0) -> Any:
    """`value` with every array in it a copy of its own (not a view of the file's buffer)."""
    if isinstance(value, np.ndarray):
        return value.copy()
    if depth < _MAX_DEPTH and isinstance(value, list):
        return [_own(v, depth + 1) for v in value]
    if depth < _MAX_DEPTH and isinstance(value, tuple) and not hasattr(value, "_fields"):
        return tuple(_own(v, depth + 1) for v in value)
    if depth < _MAX_DEPTH and isinstance(value, dict):
        return {k: _own(v, depth + 1) for k, v in value.items()}
    return value
