"""Turn pydantic validation errors into located diagnostics with the valid options."""

from __future__ import annotations

import types
import typing
from typing import Any

from pydantic import BaseModel, ValidationError

from .diagnostics import Diagnostic, did_you_mean
from .yamlio import SourceMap

__all__ = ["diagnostics_from_validation", "model_keys"]


def model_keys(model: type[BaseModel]) -> tuple[str, ...]:
    """The YAML keys a model accepts (aliases where set)."""
    return tuple(sorted(f.alias or n for n, f in model.model_fields.items()))


def _models_in(annotation: Any) -> list[type[BaseModel]]:
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return [annotation]
    out: list[type[BaseModel]] = []
    for arg in typing.get_args(annotation):
        out.extend(_models_in(arg))
    return out


def _model_at(root: type[BaseModel], loc: tuple) -> type[BaseModel] | None:
    """The model whose fields are keys at `loc` (walks fields, dict values and list items)."""
    current: Any = root
    for part in loc:
        current = _optional_model(current)
        if isinstance(current, type) and issubclass(current, BaseModel):
            field = next(
                (f for n, f in current.model_fields.items() if (f.alias or n) == part), None
            )
            if field is None:
                return None
            current = field.annotation
            continue
        origin = typing.get_origin(current)
        if origin in (typing.Union, types.UnionType) or origin is typing.Annotated:
            args = [a for a in typing.get_args(current) if a is not type(None)]
            current = next((a for a in args if typing.get_origin(a) in (dict, list)), args[0])
            if typing.get_origin(current) is typing.Annotated:
                current = typing.get_args(current)[0]
        origin = typing.get_origin(current)
        if origin is dict:
            current = typing.get_args(current)[1]
        elif origin is list:
            current = typing.get_args(current)[0]
        else:
            return None
        models = _models_in(current)
        if models:
            current = models[0]
    current = _optional_model(current)
    return current if isinstance(current, type) and issubclass(current, BaseModel) else None


def _optional_model(annotation: Any) -> Any:
    """The model of an optional model field (`RobotGains | None`), else `annotation`."""
    origin = typing.get_origin(annotation)
    if origin in (typing.Union, types.UnionType):
        args = [a for a in typing.get_args(annotation) if a is not type(None)]
        if len(args) == 1 and isinstance(args[0], type) and issubclass(args[0], BaseModel):
            return args[0]
    return annotation


def _clean_loc(loc: tuple, data: Any) -> tuple:
    """Drop union-member tags pydantic inserts into `loc` (parts that are not in the data)."""
    out: list = []
    node = data
    for part in loc:
        if isinstance(node, dict) and part in node:
            out.append(part)
            node = node[part]
        elif isinstance(node, list) and isinstance(part, int) and 0 <= part < len(node):
            out.append(part)
            node = node[part]
        elif isinstance(node, dict) and part == node.get("kind"):
            continue  # the tag of a discriminated union (`faults[0].push.force_n`)
        elif isinstance(node, dict) and not isinstance(part, int) and "[" not in str(part):
            out.append(part)  # a missing or extra key: keep it, it is the subject
            node = None
        else:
            continue
    return tuple(out)


def diagnostics_from_validation(
    exc: ValidationError,
    root: type[BaseModel],
    source: SourceMap,
    data: Any,
    prefix: tuple = (),
) -> list[Diagnostic]:
    """One diagnostic per distinct location, with the valid keys or values where known."""
    by_path: dict[tuple, Diagnostic] = {}
    for err in exc.errors(include_url=False):
        loc = _clean_loc(tuple(err["loc"]), data)
        kind = err["type"]
        msg = str(err["msg"]).removeprefix("Value error, ")
        valid: tuple[str, ...] = ()
        if kind == "extra_forbidden":
            model = _model_at(root, loc[:-1])
            valid = model_keys(model) if model else ()
            msg = f"unknown key {loc[-1]!r}{did_you_mean(loc[-1], valid)}"
        elif kind == "missing":
            msg = f"missing required key {loc[-1]!r}"
        elif kind == "literal_error":
            expected = str(err.get("ctx", {}).get("expected", ""))
            valid = tuple(v.strip().strip("'") for v in expected.replace(" or ", ",").split(","))
            msg = f"invalid value {err.get('input')!r}"
        elif (
            "input" in err
            and kind not in ("model_type", "dict_type")
            and not (kind == "value_error" and isinstance(err["input"], dict))  # the whole entry
        ):
            msg = f"{msg}, got {err['input']!r}"
        full = (*prefix, *loc)
        if full in by_path:
            prev = by_path[full]
            if msg not in prev.message:
                by_path[full] = source.diag(full, f"{prev.message}; or {msg}", prev.valid or valid)
            continue
        by_path[full] = source.diag(full, msg, valid)
    # A union reports "should be a valid list" for the arm that did not apply; when deeper
    # errors exist under that path, they are the useful ones.
    paths = [d.path for d in by_path.values()]
    return [
        d
        for d in by_path.values()
        if not (
            d.message.startswith("Input should be a valid")
            and any(p.startswith(d.path + ".") or p.startswith(d.path + "[") for p in paths)
        )
    ]
