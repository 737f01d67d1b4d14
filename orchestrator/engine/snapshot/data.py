"""Plain data: what a snapshot holds instead of objects.

A value is *data* as skills/plain_state.py says (numbers, strings, arrays, pydantic dumps, and
lists and dicts of them). `encode` turns data into a JSON tree plus a dict of arrays (each
array in the tree is `{"$array": NAME}`, a tuple `{"$tuple": [...]}`, a dict with integer
keys `{"$items": [[key, value], ...]}`, a non-finite float
`{"$float": "nan"}`); `decode` is
its inverse and never builds anything else: no class is looked up by name, no callable named
in a file is called. `objects` walks a run's graph to find what a snapshot records
(generators, skills, checks).
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from typing import Any

import numpy as np
from pydantic import BaseModel

from ...skills.plain_state import is_data, plain_state

__all__ = ["decode", "encode", "first_difference", "objects", "is_data", "plain_state"]

_ATOMS = (bool, int, str, type(None))
_MAX_DEPTH = 40
"""Nesting of a snapshot's data (a machine nested in a parallel branch of a nested machine...)."""


class _Encoder:
    def __init__(self, prefix: str) -> None:
        self.prefix = prefix
        self.arrays: dict[str, np.ndarray] = {}

    def tree(self, value: Any, depth: int = 0) -> Any:
        if depth > _MAX_DEPTH:
            raise ValueError("data nested too deep")
        if isinstance(value, np.ndarray):
            name = f"{self.prefix}{len(self.arrays)}"
            self.arrays[name] = np.array(value, copy=True)
            return {"$array": name}
        if isinstance(value, BaseModel):
            return self.tree(value.model_dump(mode="python"), depth + 1)
        if isinstance(value, (np.bool_, np.integer)):
            return value.item()
        if isinstance(value, (float, np.floating)):
            f = float(value)
            return f if math.isfinite(f) else {"$float": repr(f)}
        if isinstance(value, _ATOMS):
            return value
        if isinstance(value, tuple):
            return {"$tuple": [self.tree(v, depth + 1) for v in value]}
        if isinstance(value, list):
            return [self.tree(v, depth + 1) for v in value]
        if isinstance(value, dict):
            if all(isinstance(k, str) for k in value):
                return {k: self.tree(v, depth + 1) for k, v in value.items()}
            return {"$items": [[_key(k), self.tree(v, depth + 1)] for k, v in value.items()]}
        return {"$repr": type(value).__name__}  # not data: named, never brought back


def _key(k: Any) -> Any:
    return (
        k.item() if isinstance(k, (np.integer, np.bool_)) else k if isinstance(k, int) else str(k)
    )


def encode(value: Any, prefix: str) -> tuple[Any, dict[str, np.ndarray]]:
    """`value` as (JSON tree, arrays named `<prefix><n>`)."""
    enc = _Encoder(prefix)
    return enc.tree(value), enc.arrays


def decode(tree: Any, arrays: dict[str, np.ndarray], depth: int = 0) -> Any:
    """The data `encode` wrote (unknown markers stay as they are).

    Raises:
        ValueError: A reference to an array the file does not hold, or a tree too deep.
    """
    if depth > 2 * _MAX_DEPTH + 2:  # a tuple's marker is two levels
        raise ValueError("data nested too deep")
    if isinstance(tree, list):
        return [decode(v, arrays, depth + 1) for v in tree]
    if isinstance(tree, dict):
        if set(tree) == {"$array"}:
            name = tree["$array"]
            if not isinstance(name, str) or name not in arrays:
                raise ValueError(f"no array {str(name)[:40]!r} in the file")
            return arrays[name]
        if set(tree) == {"$items"} and isinstance(tree["$items"], list):
            pairs = tree["$items"]
            if not all(isinstance(p, list) and len(p) == 2 and isinstance(p[0], (int, str))
                       for p in pairs):  # fmt: skip
                raise ValueError("a mapping's items are not [key, value] pairs")
            return {k: decode(v, arrays, depth + 1) for k, v in pairs}
        if set(tree) == {"$tuple"} and isinstance(tree["$tuple"], list):
            return tuple(decode(v, arrays, depth + 1) for v in tree["$tuple"])
        if set(tree) == {"$float"} and tree["$float"] in ("nan", "inf", "-inf"):
            return float(tree["$float"])
        return {k: decode(v, arrays, depth + 1) for k, v in tree.items()}
    return tree


def first_difference(a: Any, b: Any, path: str = "") -> str | None:
    """Where two decoded trees first differ (arrays bit for bit), or None."""
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        if not (isinstance(a, np.ndarray) and isinstance(b, np.ndarray)):
            return path or "."
        same = a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()
        return None if same else (path or ".")
    if isinstance(a, dict) and isinstance(b, dict):
        for k in sorted(set(a) | set(b)):
            if k not in a or k not in b:
                return f"{path}.{k}"
            found = first_difference(a[k], b[k], f"{path}.{k}")
            if found is not None:
                return found
        return None
    if isinstance(a, (list, tuple)) and isinstance(b, (list, tuple)):
        if len(a) != len(b):
            return f"{path} (length {len(a)} != {len(b)})"
        for i, (x, y) in enumerate(zip(a, b, strict=True)):
            found = first_difference(x, y, f"{path}[{i}]")
            if found is not None:
                return found
        return None
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return None
    return None if type(a) is type(b) and a == b else (path or ".")


def objects(root: Any, limit: int = 100_000) -> Iterator[tuple[str, Any]]:
    """Every object reachable from `root` through attributes, lists, tuples and dicts, with
    the path it is first met at (depth first, in attribute order: the same run gives the same
    paths in any process). MuJoCo structs, arrays, classes, functions and modules are not
    entered."""
    seen: set[int] = set()
    stack: list[tuple[str, Any]] = [("", root)]
    while stack and len(seen) < limit:
        path, obj = stack.pop()
        if isinstance(obj, (*_ATOMS, float, np.ndarray, type)) or id(obj) in seen:
            continue
        if callable(obj) and not hasattr(obj, "__dict__"):
            continue
        if isinstance(obj, BaseModel) or type(obj).__module__.startswith(("mujoco", "pinocchio")):
            continue
        seen.add(id(obj))
        yield path, obj
        if isinstance(obj, dict):
            items = [(f"{path}[{k!r}]", v) for k, v in obj.items() if isinstance(k, (str, int))]
        elif isinstance(obj, (list, tuple)) or type(obj).__name__ == "deque":
            items = [(f"{path}[{i}]", v) for i, v in enumerate(obj)]
        else:
            attrs = getattr(obj, "__dict__", None)
            if not isinstance(attrs, dict) or callable(obj):
                continue
            items = [(f"{path}.{k}", v) for k, v in attrs.items()]
        stack.extend(reversed(items))
