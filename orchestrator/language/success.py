"""Static checks of a scenario's `success:` entries: the kind, its parameters, the names.

Each entry is `{kind: KIND, ...}`; the kind's `Params` (orchestrator/success/) validate the
rest. Like guards, entries are checked here with located messages rather than by the
scenario model, so an unknown kind says which kinds there are (and the closest one).
"""

from __future__ import annotations

from typing import Any

from pydantic import ValidationError

from ..success import CheckParams, blackboard_fields, check_kinds, get_check
from .diagnostics import Diagnostic, did_you_mean, format_path
from .param_values import pose_problem
from .pydantic_errors import diagnostics_from_validation
from .refs import parse_ref
from .yamlio import SourceMap

__all__ = ["check_success_names", "typed_success", "validate_success"]


def validate_success(raw: Any, src: SourceMap, at: tuple = ("success",)) -> list[Diagnostic]:
    """Unknown kinds and bad parameters of the `success:` mapping as written."""
    if not isinstance(raw, dict):
        return [src.diag(at, f"`success` is a mapping of named checks, got {raw!r}")]
    kinds = tuple(check_kinds())
    out = []
    for name, entry in raw.items():
        eat = (*at, name)
        if not isinstance(entry, dict):
            out.append(src.diag(eat, f"a success check is a mapping with a `kind`, got {entry!r}"))
            continue
        kind = entry.get("kind")
        if kind is None:
            out.append(src.diag(eat, "missing required key 'kind'", kinds))
            continue
        if kind not in kinds:
            hint = did_you_mean(kind, kinds)
            out.append(src.diag((*eat, "kind"), f"unknown success check {kind!r}{hint}", kinds))
            continue
        out += _params_problems(get_check(kind).Params, entry, src, eat)
    return out


def _params_problems(
    params: type[CheckParams], entry: dict[str, Any], src: SourceMap, at: tuple
) -> list[Diagnostic]:
    """What is wrong with an entry's parameters; one given as `$key` is validated when the run
    reads it from the blackboard (`check_success_names` checks that the key exists)."""
    later = set(blackboard_fields(params, entry))
    now = {k: v for k, v in entry.items() if k not in later}
    try:
        params.model_validate(now)
    except ValidationError as exc:
        skip = {format_path((*at, name)) for name in later}  # a `$key` left out is no error
        found = diagnostics_from_validation(exc, params, src, now, at)
        return [d for d in found if d.path not in skip]
    return []


def typed_success(success: dict[str, Any]) -> dict[str, CheckParams | dict[str, Any]]:
    """Each entry as its kind's `Params` (after `validate_success` found nothing wrong); one
    with `$key` parameters is kept as written, validated when the run has read them."""
    out: dict[str, CheckParams | dict[str, Any]] = {}
    for name, entry in success.items():
        data = dict(entry) if isinstance(entry, CheckParams) else entry
        params = get_check(str(data["kind"])).Params
        if blackboard_fields(params, data):
            out[name] = params.model_construct(**data)
        else:
            out[name] = params.model_validate(data)
    return out


def check_success_names(
    success: dict[str, Any],
    src: SourceMap,
    objects: list[str],
    markers: list[str],
    keys: set[str] | None,
) -> list[Diagnostic]:
    """Parameters that name scene objects (`SCENE_OBJECT`) or targets (`SCENE_TARGET`: an
    object, a marker, `[x, y, z]` or `$key`) name ones the scenario has.

    Args:
        success: The scenario's validated checks.
        src: Where the scenario's keys are.
        objects: The scene's free objects.
        markers: The scene's markers.
        keys: The machine's blackboard keys (None: no machine to check `$key` against).
    """
    out = []
    for name, check in success.items():
        if not isinstance(check, CheckParams):
            continue  # `validate_success` says what is wrong with it
        for field, info in type(check).model_fields.items():
            extra = info.json_schema_extra
            kind = extra.get("scene_ref") if isinstance(extra, dict) else None
            value = getattr(check, field)
            at = ("success", name, field)
            ref = parse_ref(value)
            if isinstance(value, str) and value[:1] == "$" and ref is None:
                out.append(src.diag(at, f"{value!r} is not a blackboard read (`$key`)"))
                continue
            if (kind not in ("object", "target") and ref is None) or value is None:
                continue
            if ref is not None:
                if keys is not None and ref[0] not in keys:
                    out.append(
                        src.diag(
                            at,
                            f"the machine has no blackboard key {ref[0]!r}"
                            f"{did_you_mean(ref[0], keys)}",
                            tuple(sorted(keys)),
                        )
                    )
            elif kind == "object" and value not in objects:
                hint = did_you_mean(value, objects)
                out.append(src.diag(at, f"no scene object {value!r}{hint}", tuple(objects)))
            elif kind == "target" and isinstance(value, str) and value not in markers + objects:
                names = markers + objects
                hint = did_you_mean(value, names)
                out.append(src.diag(at, f"no marker or object {value!r}{hint}", tuple(names)))
            elif kind == "target" and not isinstance(value, str):
                problem = pose_problem(value)
                if problem is not None:
                    out.append(src.diag(at, f"{value!r} is {problem}"))
    return out
