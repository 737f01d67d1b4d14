"""`orchestrator validate`: check machines and scenarios, telling which is which."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from ..exceptions import ConfigError
from .bundled import is_file, resolve_file
from .diagnostics import Diagnostic
from .load import load_machine, load_scenario
from .yamlio import load_yaml

__all__ = ["validate_paths"]


def _kind(ref: str) -> tuple[str, str] | None:
    path = Path(ref)
    if is_file(path):
        try:
            data = load_yaml(path).data
        except ConfigError:
            return "machine" if "machine" in path.parts else "scenario", str(path)
        if isinstance(data, dict) and "states" in data:
            return "machine", str(path)
        if isinstance(data, dict) and (
            "scene" in data or "robot" in data or isinstance(data.get("machine"), str)
        ):
            return "scenario", str(path)
        return ("machine" if isinstance(data, dict) and "initial" in data else "scenario"), str(
            path
        )
    if resolve_file(ref, "scenarios") is not None:
        return "scenario", ref
    if resolve_file(ref, "machines") is not None:
        return "machine", ref
    return None


def validate_paths(
    refs: list[str], allow_paths: Sequence[Path | str] = ()
) -> tuple[list[Diagnostic], list[tuple[str, str]]]:
    """Every problem in `refs`, and the (kind, name) of each file that passed.

    Args:
        refs: Files or bundled names.
        allow_paths: Directories includes may name besides each file's own tree.
    """
    problems: list[Diagnostic] = []
    ok: list[tuple[str, str]] = []
    for ref in refs:
        kind = _kind(ref)
        if kind is None:
            problems.append(
                Diagnostic(ref, 0, 0, "<file>", "no such file, bundled scenario or machine")
            )
            continue
        try:
            if kind[0] == "machine":
                load_machine(kind[1], allow_paths=allow_paths)
            else:
                load_scenario(kind[1], allow_paths=allow_paths)
        except ConfigError as exc:
            problems += exc.diagnostics
            continue
        ok.append(kind)
    return problems, ok
