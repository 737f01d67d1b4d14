"""Success criteria, evaluated at the end of a run, each with what it measured.

Each entry of a scenario's `success:` is judged by the check its `kind` names (bundled in
orchestrator/success/, a plugin's, or one from a folder of your own).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from ..success import CheckParams, SuccessCheck, get_check
from .context import Context

__all__ = ["errors", "evaluate"]


def _check(entry: CheckParams | Mapping[str, Any]) -> SuccessCheck:
    """The check of a scenario entry (validated by the language; a raw mapping is validated
    here, for a Scenario built without `load_scenario`)."""
    kind = entry.kind if isinstance(entry, CheckParams) else str(entry["kind"])
    cls = get_check(kind)
    params = entry if isinstance(entry, cls.Params) else cls.Params.model_validate(entry)
    return cls(params)


def evaluate(
    ctx: Context, checks: Mapping[str, CheckParams | Mapping[str, Any]]
) -> dict[str, tuple[bool, str]]:
    """Name -> (passed, what was measured against what limit), for every criterion."""
    return {name: tuple(_check(entry).evaluate(ctx)) for name, entry in checks.items()}  # type: ignore[misc]


def errors(ctx: Context, checks: Mapping[str, CheckParams | Mapping[str, Any]]) -> dict[str, float]:
    """The figures every criterion measures, as metrics prefixed with its name (`object_at`:
    `<name>_xy_error_mm`, the distance in the table plane from the object's centre to its
    target [mm])."""
    out: dict[str, float] = {}
    for name, entry in checks.items():
        for key, value in _check(entry).metrics(ctx).items():
            out[f"{name}_{key}"] = value
    return out
