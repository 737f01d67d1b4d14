"""`orchestrator validate`: check machines and scenarios, telling which is which."""

from __future__ import annotations

from pathlib import Path

from ..exceptions import ConfigError
from .bundled import resolve_file
from .diagnostics import Diagnostic
from .load import load_machine, load_scenario
from .yamlio import load_yaml

__all__ = ["file_kind", "validate_paths"]


def file_kind(ref: str) -> tuple[str, str] | None:
    """(`machine` or `scenario`, the file or bundled name) of a reference; None if not found."""
    path = Path(ref)
    if path.is_file():
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


def _expand(refs: list[str]) -> list[str]:
    """A folder stands for every YAML file below it (sorted)."""
    out = []
    for ref in refs:
        path = Path(ref)
        if path.is_dir():
            found = sorted(p for p in path.rglob("*") if p.suffix in (".yaml", ".yml"))
            out += [str(p) for p in found] or [ref]
        else:
            out.append(ref)
    return out


def validate_paths(refs: list[str]) -> tuple[list[Diagnostic], list[tuple[str, str]]]:
    """Every problem in `refs`, and the (kind, name) of each file that passed."""
    problems: list[Diagnostic] = []
    ok: list[tuple[str, str]] = []
    for ref in _expand(refs):
        kind = file_kind(ref)
        if kind is None:
            what = "a folder without YAML files" if Path(ref).is_dir() else "no such file"
            problems.append(Diagnostic(ref, 0, 0, "<file>", f"{what}, bundled scenario or machine"))
            continue
        try:
            if kind[0] == "machine":
                load_machine(kind[1])
            else:
                load_scenario(kind[1])
        except ConfigError as exc:
            problems += exc.diagnostics
            continue
        ok.append(kind)
    return problems, ok
