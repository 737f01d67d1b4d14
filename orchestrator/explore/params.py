"""The parameters a scenario exposes, read from its schema: every `--set`-able value with a
validated range.

`scenario_parameters` walks the validated `Scenario` (its `scene` and `perception`: the cell
and what the robot senses of it) along the pydantic models that validated it. A number whose
field has a lower and an upper bound is a parameter over exactly those bounds; a fixed-length
list of bounded numbers (a position, a size, a colour, a randomization range) is one parameter
per element, addressed the way `--set` addresses it (`scene.objects.cube.xy.0`); a `Literal`
or a boolean is a choice. Items of a list are named by their `name` where they have one.
Nothing is listed by hand: a new field with a validated range is explored as soon as it is
written. The robot, the physics, the guards and the success checks are not explored: they
are the cell's calibration and its acceptance criteria, not the workload.
"""

from __future__ import annotations

import json
import math
import types
import typing
from collections.abc import Mapping
from dataclasses import dataclass, replace
from typing import Any, Literal

import annotated_types as at
from pydantic import BaseModel

__all__ = [
    "EXPLORED_ROOTS",
    "Parameter",
    "override_text",
    "override_texts",
    "scenario_parameters",
]

EXPLORED_ROOTS = ("scene", "perception")
"""The scenario's sections whose values are explored."""


@dataclass(frozen=True)
class Parameter:
    """One explored value.

    Attributes:
        path: Its dotted `--set` path (`scene.objects.cube.mass`).
        nominal: Its value in the scenario as written (defaults included).
        lo: Lowest value validation accepts (numbers; None for a choice).
        hi: Highest value validation accepts (numbers; None for a choice).
        integer: The value is a whole number (a count).
        choices: The values of a choice (a `Literal`, a boolean); empty for a number.
        whole: For an element of a list the file does not write (its default): the whole
            list at nominal (`--set` then writes the list, this element changed).
    """

    path: str
    nominal: Any
    lo: float | None = None
    hi: float | None = None
    integer: bool = False
    choices: tuple[Any, ...] = ()
    whole: tuple[Any, ...] | None = None

    def distance(self, value: Any) -> float:
        """How far `value` is from nominal, as a share of the validated range (0..1)."""
        if self.choices:
            return 0.0 if value == self.nominal else 1.0
        assert self.lo is not None and self.hi is not None
        span = self.hi - self.lo
        return abs(float(value) - float(self.nominal)) / span if span > 0 else 0.0


def override_text(path: str, value: Any) -> str:
    """The `--set` text that gives `path` the value `value` (JSON is YAML)."""
    return f"{path}={json.dumps(value)}"


def override_texts(values: Mapping[str, Any], params: Mapping[str, Parameter]
                   ) -> tuple[str, ...]:  # fmt: skip
    """The `--set` texts of moved values (path -> value), in parameter order; the elements of
    a list the file does not write go into one text for the whole list."""
    out: list[str] = []
    lists: dict[str, list[Any]] = {}
    for path in (p for p in params if p in values):
        param = params[path]
        if param.whole is None:
            out.append(override_text(path, values[path]))
            continue
        head, _, index = path.rpartition(".")
        lists.setdefault(head, list(param.whole))[int(index)] = values[path]
    out.extend(override_text(head, whole) for head, whole in lists.items())
    return tuple(out)


def _bounds(metadata: list[Any]) -> tuple[float | None, float | None]:
    lo = hi = None
    for m in metadata:
        if isinstance(m, at.Ge):
            lo = float(m.ge)  # type: ignore[arg-type]
        elif isinstance(m, at.Gt):
            lo = math.nextafter(float(m.gt), math.inf)  # type: ignore[arg-type]
        elif isinstance(m, at.Le):
            hi = float(m.le)  # type: ignore[arg-type]
        elif isinstance(m, at.Lt):
            hi = math.nextafter(float(m.lt), -math.inf)  # type: ignore[arg-type]
        elif hasattr(m, "metadata"):  # a FieldInfo inside Annotated[...]
            a, b = _bounds(list(m.metadata))
            lo, hi = a if a is not None else lo, b if b is not None else hi
    return lo, hi


def _unwrap(annotation: Any) -> tuple[Any, list[Any]]:
    """The annotation without `Annotated` and `| None`, with the metadata it carried."""
    metadata: list[Any] = []
    while True:
        origin = typing.get_origin(annotation)
        if origin is typing.Annotated:
            annotation, *extra = typing.get_args(annotation)
            metadata.extend(extra)
        elif origin in (typing.Union, types.UnionType):
            args = [a for a in typing.get_args(annotation) if a is not type(None)]
            if len(args) != 1:
                return annotation, metadata
            annotation = args[0]
        else:
            return annotation, metadata


def _scalar(path: str, value: Any, annotation: Any, metadata: list[Any]) -> Parameter | None:
    annotation, more = _unwrap(annotation)
    metadata = [*metadata, *more]
    if annotation is bool and isinstance(value, bool):
        return Parameter(path, value, choices=(False, True))
    if typing.get_origin(annotation) is Literal:
        options = typing.get_args(annotation)
        return Parameter(path, value, choices=tuple(options)) if len(options) > 1 else None
    if annotation in (int, float) and isinstance(value, (int, float)):
        lo, hi = _bounds(metadata)
        if lo is None or hi is None or not hi > lo:
            return None
        return Parameter(path, value, lo, hi, integer=annotation is int)
    return None


def _raw_item(raw: Any, key: str, i: int) -> Any:
    """The item of the file's list `raw` that `--set` finds as `key` (by name, else index)."""
    if not isinstance(raw, list):
        return _MISSING
    for item in raw:
        if isinstance(item, dict) and item.get("name") == key:
            return item
    return raw[i] if key == str(i) and i < len(raw) else _MISSING


_MISSING = object()
"""An item the file does not write (one the loader generated, e.g. a bin's walls)."""


def _walk(value: Any, annotation: Any, metadata: list[Any], path: str, raw: Any
          ) -> list[Parameter]:  # fmt: skip
    annotation, more = _unwrap(annotation)
    metadata = [*metadata, *more]
    if isinstance(value, BaseModel):
        return _model(value, path, raw)
    origin = typing.get_origin(annotation)
    if origin is list and isinstance(value, list):
        (item_ann,) = typing.get_args(annotation) or (Any,)
        out: list[Parameter] = []
        fixed = any(isinstance(m, at.MaxLen) for m in metadata) and any(
            isinstance(m, at.MinLen) for m in metadata
        )
        for i, item in enumerate(value):
            name = getattr(item, "name", None)
            key = str(name) if isinstance(name, str) and name else str(i)
            if isinstance(item, BaseModel):
                raw_item = _raw_item(raw, key, i)
                if raw_item is not _MISSING:  # not an item the loader generated
                    out.extend(_model(item, f"{path}.{key}", raw_item))
            elif fixed:  # a position, a size, a range: one parameter per element
                p = _scalar(f"{path}.{i}", item, item_ann, [])
                if p is not None:
                    out.append(p if isinstance(raw, list) else replace(p, whole=tuple(value)))
        return out
    if origin is dict and isinstance(value, dict):
        _, item_ann = typing.get_args(annotation) or (Any, Any)
        out = []
        for key, item in value.items():
            sub = raw.get(key) if isinstance(raw, dict) else None
            out.extend(_walk(item, item_ann, [], f"{path}.{key}", sub))
        return out
    p = _scalar(path, value, annotation, metadata)
    return [p] if p is not None else []


def _model(model: BaseModel, path: str, raw: Any) -> list[Parameter]:
    out: list[Parameter] = []
    for name, info in type(model).model_fields.items():
        key = info.alias or name
        if key == "name":
            continue
        sub = raw.get(key) if isinstance(raw, dict) else None
        out.extend(_walk(getattr(model, name), info.annotation, list(info.metadata),
                         f"{path}.{key}", sub))  # fmt: skip
    return out


def scenario_parameters(
    scenario: BaseModel, raw: dict[str, Any], roots: tuple[str, ...] = EXPLORED_ROOTS
) -> list[Parameter]:
    """Every explored parameter of a validated scenario, in the order its schema lists them.

    Args:
        scenario: The validated `Scenario` (its values are the nominal ones).
        raw: The scenario file's mapping as written: list items it does not write (ones the
            loader generates, as a bin's walls) cannot be `--set` and are not explored.
        roots: Its sections to explore.
    """
    out: list[Parameter] = []
    fields = type(scenario).model_fields
    for root in roots:
        if root in fields and getattr(scenario, root) is not None:
            info = fields[root]
            out.extend(_walk(getattr(scenario, root), info.annotation, list(info.metadata), root,
                             raw.get(root)))  # fmt: skip
    return out
