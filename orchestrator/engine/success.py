"""Success criteria, evaluated at the end of a run, each with what it measured.

Each entry of a scenario's `success:` is judged by the check its `kind` names (bundled in
orchestrator/success/, a plugin's, or one from a folder of your own). A parameter given as
`$key` is read from the blackboard as the run ended, then validated by the check's `Params`.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from pydantic import ValidationError

from ..exceptions import OrchestratorError
from ..success import CheckParams, SuccessCheck, blackboard_fields, get_check
from .context import Context

__all__ = ["errors", "evaluate"]


class _Unresolved(OrchestratorError):
    """A `$key` parameter could not be read, or its value is not what the check takes."""


def _check(entry: CheckParams | Mapping[str, Any], ctx: Context) -> SuccessCheck:
    """The check of a scenario entry (validated by the language; a raw mapping is validated
    here, for a Scenario built without `load_scenario`), its `$key` parameters read first."""
    raw = dict(entry)
    data = dict(raw)
    cls = get_check(str(data["kind"]))
    later = blackboard_fields(cls.Params, data)
    if not later and isinstance(entry, cls.Params):
        return cls(entry)
    for name in later:
        ref = data[name]
        try:
            value = ctx.blackboard.resolve(ref)
        except OrchestratorError as exc:
            raise _Unresolved(f"{name}: {ref}: {exc}") from None
        data[name] = value.tolist() if hasattr(value, "tolist") else value
    try:
        params = cls.Params.model_validate(data)
    except ValidationError as exc:
        problems = "; ".join(
            f"{'.'.join(map(str, e['loc']))}: {e['msg']}, got {e.get('input')!r}"
            for e in exc.errors(include_url=False)
        )
        read = ", ".join(f"{n}: {raw[n]} = {data[n]!r}" for n in later)
        raise _Unresolved(
            problems + (f" (read from the blackboard: {read})" if read else "")
        ) from None
    return cls(params)


def evaluate(
    ctx: Context, checks: Mapping[str, CheckParams | Mapping[str, Any]]
) -> dict[str, tuple[bool, str]]:
    """Name -> (passed, what was measured against what limit), for every criterion; one whose
    `$key` parameter cannot be read (or is not what it takes) fails, saying why."""
    out: dict[str, tuple[bool, str]] = {}
    for name, entry in checks.items():
        try:
            out[name] = tuple(_check(entry, ctx).evaluate(ctx))  # type: ignore[assignment]
        except _Unresolved as exc:
            out[name] = (False, f"parameter {exc}")
    return out


def errors(ctx: Context, checks: Mapping[str, CheckParams | Mapping[str, Any]]) -> dict[str, float]:
    """The figures every criterion measures, as metrics prefixed with its name (`object_at`:
    `<name>_xy_error_mm`, the distance in the table plane from the object's centre to its
    target [mm])."""
    out: dict[str, float] = {}
    for name, entry in checks.items():
        try:
            check = _check(entry, ctx)
        except _Unresolved:
            continue  # `evaluate` says why
        for key, value in check.metrics(ctx).items():
            out[f"{name}_{key}"] = value
    return out
