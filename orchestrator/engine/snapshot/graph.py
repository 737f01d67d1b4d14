"""The plain data of every object of a run, by the path it is reached at, and how it is put
back on a run built the normal way (restore.py).

`capture_graph` walks the run's objects (data.py `objects`, pruned where a declared
`snapshot_state` owns the data: a skill, a success check) and records each one's plain-data
attributes (skills/plain_state.py) with its type's name. `apply_graph` walks the rebuilt run
the same way and puts each recorded attribute back on the object found at the same path, if
that object is of the same type: an array into the array already there (`np.copyto`: views
of it stay views), anything else set. An array that is a view of other memory (MjData) is
neither recorded nor written: MuJoCo's state brings it back. A pydantic model is
configuration, built from the scenario: never written. Nothing recorded is called or turned
into a class: a path of the file only selects an object the rebuilt run already holds.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Iterator
from typing import Any

from pydantic import BaseModel

from ...skills.plain_state import attributes, holds_view, is_data, restore_plain
from ...world.pose import Pose
from .data import objects

__all__ = ["apply_attributes", "apply_graph", "capture_graph", "type_name", "walk"]


def type_name(obj: Any) -> str:
    cls = type(obj)
    return f"{cls.__module__}.{cls.__qualname__}"


_NOT_STATE = ("transitions.", "orchestrator.language.", "ruckig")
"""Modules whose objects hold no run state of their own (the machine's definition, the
`transitions` bookkeeping the executor rebuilds from it, ruckig's trajectories, which their
owners rebuild from their own data)."""


def walk(root: Any, prune: Callable[[Any], bool]) -> Iterator[tuple[str, Any]]:
    """`objects(root)` but for what `prune` says holds a declared state of its own (it is
    yielded, not entered, and its attributes are not recorded here) and what is in
    `_NOT_STATE`."""
    pruned: list[str] = []
    for path, obj in objects(root):
        if any(path.startswith(p) for p in pruned):
            continue
        if type(obj).__module__.startswith(_NOT_STATE):
            pruned.append(path + ".")
            pruned.append(path + "[")
            continue
        yield path, obj
        if prune(obj):
            pruned.append(path + ".")
            pruned.append(path + "[")


def _frozen(obj: Any) -> bool:
    """A frozen dataclass: made once, never changed (its maker's state says how)."""
    params = getattr(type(obj), "__dataclass_params__", None)
    return bool(params is not None and params.frozen)


def _rows(value: Any, rows: tuple[type, ...]) -> dict[str, Any] | None:
    """A list or dict of records of one declared type (a log's events, the task log's
    entries) as `{"$rows": type name, "items": [fields...]}` (dict: `"keys"` too)."""
    items = list(value.values()) if isinstance(value, dict) else value
    if not isinstance(value, (list, dict)) or not items:
        return None
    cls = type(items[0])
    if cls not in rows or not all(type(v) is cls for v in items):
        return None
    fields = [{f.name: getattr(v, f.name) for f in dataclasses.fields(v)} for v in items]
    if not is_data(fields):
        return None
    out: dict[str, Any] = {"$rows": cls.__name__, "items": fields}
    if isinstance(value, dict):
        out["keys"] = list(value)
    return out


VALUES: tuple[type[BaseModel], ...] = (Pose,)
"""Pydantic models that are a run's state, not its configuration, where a run holds them
(the IK's target pose): recorded as their fields, made again by their own validation."""


def _own_data(obj: Any, rows: tuple[type, ...] = ()) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for key, value in sorted(attributes(obj).items()):
        table = _rows(value, rows)
        if table is not None:
            out[key] = table
            continue
        if type(value) in VALUES:
            out[key] = {"$value": type(value).__name__, "fields": value.model_dump()}
            continue
        if isinstance(value, BaseModel) or not is_data(value) or holds_view(value):
            continue  # configuration; a view (of MjData, or of an array recorded where it lives)
        out[key] = value
    return out


def capture_graph(
    root: Any, prune: Callable[[Any], bool], rows: tuple[type, ...] = ()
) -> dict[str, Any]:
    """`{path: {"type": name, "attrs": {...}}}` of every object reachable from `root` that
    holds plain data (containers are walked, not recorded)."""
    out: dict[str, Any] = {}
    for path, obj in walk(root, prune):
        if isinstance(obj, (list, tuple, dict)) or type(obj).__name__ == "deque":
            continue
        if type(obj) in rows or prune(obj) or _frozen(obj):
            continue  # recorded with the list or dict that holds it; its own state
        attrs = _own_data(obj, rows)
        if attrs:
            out[path] = {"type": type_name(obj), "attrs": attrs}
    return out


def apply_graph(
    root: Any, recorded: dict[str, Any], prune: Callable[[Any], bool], rows: tuple[type, ...] = ()
) -> list[str]:
    """Put `recorded` (capture_graph) back on the objects of `root` at the same paths; returns
    the recorded paths no object of the same type stands at now (their state is lost)."""
    left = dict(recorded)
    for path, obj in walk(root, prune):
        rec = left.pop(path, None) if not (prune(obj) or _frozen(obj)) else None
        if rec is None:
            continue
        if rec.get("type") != type_name(obj):
            left[path] = rec
            continue
        apply_attributes(obj, rec["attrs"], path, rows)
    return sorted(left)


def apply_attributes(obj: Any, values: Any, where: str, rows: tuple[type, ...] = ()) -> None:
    """Set each recorded attribute of `obj` (skills/plain_state.py `restore_plain`), the
    records of a declared type built again from their fields.

    Raises:
        ValueError: `values` is not a mapping, or holds records of an undeclared type.
    """
    if not isinstance(values, dict):
        raise ValueError(f"{where} is not a mapping")
    values = {
        k: _rebuild_rows(v, rows, f"{where}.{k}") if isinstance(v, dict) and "$rows" in v else v
        for k, v in values.items()
    }
    for key, value in values.items():
        if isinstance(value, dict) and "$value" in value:
            cls = next((c for c in VALUES if c.__name__ == value["$value"]), None)
            if cls is None:
                raise ValueError(f"{where}.{key}: a value of an undeclared type")
            setattr(obj, key, cls.model_validate(value["fields"]))
    restore_plain(
        obj, {k: v for k, v in values.items() if not (isinstance(v, dict) and "$value" in v)}
    )


def _rebuild_rows(table: dict[str, Any], rows: tuple[type, ...], where: str) -> Any:
    """The records `_rows` wrote, each built by its declared type from its fields."""
    cls = next((c for c in rows if c.__name__ == table["$rows"]), None)
    items = table.get("items")
    if cls is None or not isinstance(items, list):
        raise ValueError(f"{where}: records of an undeclared type")
    names = {f.name for f in dataclasses.fields(cls)}
    built = []
    for fields in items:
        if not isinstance(fields, dict) or set(fields) != names:
            raise ValueError(f"{where}: a record without the fields of {cls.__name__}")
        built.append(cls(**fields))
    keys = table.get("keys")
    if keys is None:
        return built
    if not isinstance(keys, list) or len(keys) != len(built):
        raise ValueError(f"{where}: records without their keys")
    return dict(zip(keys, built, strict=True))
