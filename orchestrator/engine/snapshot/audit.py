"""Checks that keep snapshots honest as the code changes (tests and bench/snapshot_identity.py
run them; a snapshot itself never does).

* `fingerprint(root)`: the object graph as snapshots see it — every object through the
  reduction pickle uses (so through `__getstate__`, the native reducers, MuJoCo structs by
  their fields), numbers exactly, aliasing as references to the first visit. The fingerprint
  of a restored snapshot equals the original's unless restoring lost or changed something.
* `process_values(root)`: plain integers in the graph that are the `id()` of an object of the
  graph or the address of an array's memory. Neither survives a process: a dict keyed by
  `id(obj)` or a raw address kept in a Python attribute reads wrong after a restore (the
  executor's guard table and the guard bank's envelope needed care for exactly that).
"""

from __future__ import annotations

import hashlib
import io
import types
from collections.abc import Iterator
from typing import Any

import mujoco
import numpy as np

from .pickler import _UNSETTABLE, _field_view, _fields, _Memory, _Pickler, _root

__all__ = ["fingerprint", "first_difference", "process_values"]

_ATOMS = (str, bytes, bool, int, type(None))
_STRUCTS = (mujoco.MjModel, mujoco.MjData)


class _Walker:
    def __init__(self, root: Any) -> None:
        self.seen: dict[int, int] = {}
        self.keep: list[Any] = []  # keeps visited objects alive: their ids stay theirs
        self.ints: dict[int, str] = {}
        self.addresses: set[int] = set()
        self.roots: dict[int, int] = {}
        memory = _Memory()
        _Pickler(io.BytesIO(), memory).dump(root)  # meets every MuJoCo struct of the graph
        self.probe = _Pickler(io.BytesIO(), memory)

    def walk(self, obj: Any, path: str) -> Iterator[tuple[str, str]]:
        stack: list[tuple[str, Any]] = [(path, obj)]
        while stack:
            where, item = stack.pop()
            yield from self._one(where, item, stack)

    def _one(self, where: str, obj: Any, stack: list) -> Iterator[tuple[str, str]]:
        if isinstance(obj, _ATOMS):
            if type(obj) is int and abs(obj) > 1 << 32:
                self.ints.setdefault(obj, where)
            yield where, f"{type(obj).__name__}:{obj!r}"
            return
        if type(obj) is float:
            yield where, f"float:{obj.hex()}"
            return
        if id(obj) in self.seen:
            yield where, f"ref:{self.seen[id(obj)]}"
            return
        self.seen[id(obj)] = len(self.seen)
        self.keep.append(obj)
        if isinstance(obj, _STRUCTS):
            fields = sorted((k, v) for k, v in _fields(obj).items() if k not in _UNSETTABLE)
            digest = hashlib.sha256(repr(fields).encode()).hexdigest()
            yield where, f"{type(obj).__name__}:{digest}"
            return
        if isinstance(obj, (type, types.FunctionType, types.BuiltinFunctionType)):
            yield where, f"global:{getattr(obj, '__module__', '')}.{obj.__qualname__}"
            return
        if isinstance(obj, np.ndarray):
            yield from self._array(where, obj, stack)
            return
        if isinstance(obj, (list, tuple)):
            yield where, f"{type(obj).__name__}:{len(obj)}"
            stack.extend((f"{where}[{i}]", v) for i, v in reversed(list(enumerate(obj))))
            return
        if isinstance(obj, dict) and type(obj) is dict:
            yield where, f"dict:{len(obj)}"
            items = list(obj.items())
            for k, v in reversed(items):
                stack.append((f"{where}[{k!r}]", v))
                stack.append((f"{where}.key", k))
            return
        if isinstance(obj, (set, frozenset)):
            yield where, f"{type(obj).__name__}:{sorted(map(repr, obj))}"
            return
        override = self.probe.reducer_override(obj)
        rv = obj.__reduce_ex__(5) if override is NotImplemented else override
        if isinstance(rv, str):
            yield where, f"global:{rv}"
            return
        func = rv[0]
        name = getattr(func, "__qualname__", func)
        yield where, f"reduce:{getattr(func, '__module__', '')}.{name}"
        parts = [("<args>", rv[1])]
        if len(rv) > 2 and rv[2] is not None:
            parts.append(("<state>", rv[2]))
        if len(rv) > 3 and rv[3] is not None:
            parts.append(("<items>", list(rv[3])))
        if len(rv) > 4 and rv[4] is not None:
            parts.append(("<dict>", dict(rv[4])))
        stack.extend((where + name, value) for name, value in reversed(parts))

    def _array(self, where: str, arr: np.ndarray, stack: list) -> Iterator[tuple[str, str]]:
        """An array: its values, and what memory it shares with which other arrays (a view
        into a MuJoCo field, or an offset into the first array holding its memory)."""
        start = int(arr.__array_interface__["data"][0])
        self.addresses.add(start)
        digest = hashlib.sha256(np.ascontiguousarray(arr).tobytes()).hexdigest()[:16]
        strides = arr.strides if arr.size > 1 else ()  # an empty or one-value array: no layout
        kind = f"{arr.dtype.str}:{arr.shape}:{strides}:{arr.flags.writeable}:{digest}"
        override = self.probe.reducer_override(arr) if arr.base is not None else NotImplemented
        if override is not NotImplemented and override[0] is _field_view:
            struct, path, offset = override[1][:3]
            yield where, f"field:{path}+{offset}:{kind}"
            stack.append((f"{where}<struct>", struct))
            return
        root = _root(arr)
        self.keep.append(root)
        n = self.roots.setdefault(id(root), len(self.roots))
        yield where, f"array:{kind}:root{n}+{start - int(root.__array_interface__['data'][0])}"


def fingerprint(root: Any) -> list[tuple[str, str]]:
    """The graph of `root` as (path, token) pairs, in a canonical order (see the module
    docstring)."""
    return list(_Walker(root).walk(root, "root"))


def first_difference(a: list[tuple[str, str]], b: list[tuple[str, str]]) -> str | None:
    """Where two fingerprints first differ, said for a test's message; None if equal."""
    for (pa, ta), (pb, tb) in zip(a, b, strict=False):
        if (pa, ta) != (pb, tb):
            return f"{pa}: {ta[:200]} != {pb}: {tb[:200]}"
    if len(a) != len(b):
        return f"lengths differ: {len(a)} != {len(b)}"
    return None


def process_values(root: Any) -> list[str]:
    """Plain integers in `root`'s graph that are an `id()` of one of its objects or the address
    of one of its arrays: each as 'path (what it is)'."""
    walker = _Walker(root)
    for _ in walker.walk(root, "root"):
        pass
    found = []
    for value, path in walker.ints.items():
        if value in walker.seen:
            found.append(f"{path} (the id of a {type(_by_id(walker, value)).__name__})")
        elif value in walker.addresses:
            found.append(f"{path} (the address of an array's memory)")
    return found


def _by_id(walker: _Walker, value: int) -> Any:
    for obj in walker.keep:
        if id(obj) == value:
            return obj
    return None
