"""`orchestrator validate`: check machines and scenarios, telling which is which. It imports no
code a file names (a scenario's `skills:` folders stay unimported: `scenario_skills.py`)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from ..exceptions import ConfigError
from .diagnostics import Diagnostic
from .entries import file_kind
from .machines import load_machine

__all__ = ["file_kind", "validate_paths"]


_MAX_FILES = 10_000
"""Most YAML files a folder given to `validate` may stand for."""


def _expand(refs: list[str]) -> list[str]:
    """A folder stands for every YAML file below it (sorted, at most `_MAX_FILES`)."""
    out = []
    for ref in refs:
        path = Path(ref)
        if path.is_dir():
            found = []
            for p in path.rglob("*"):
                if p.suffix in (".yaml", ".yml"):
                    found.append(p)
                    if len(found) >= _MAX_FILES:
                        break
            out += [str(p) for p in sorted(found)] or [ref]
        else:
            out.append(ref)
    return out


def validate_paths(
    refs: list[str], allow_paths: Sequence[Path | str] = ()
) -> tuple[list[Diagnostic], list[tuple[str, str]]]:
    """Every problem in `refs`, and the (kind, name) of each file that passed.

    Args:
        refs: Files, folders (every YAML file below) or bundled names.
        allow_paths: Directories includes may name besides each file's own tree.
    """
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
                load_machine(kind[1], allow_paths=allow_paths)
            else:
                from .load import load_scenario  # the scenario's models: only for a scenario

                load_scenario(kind[1], allow_paths=allow_paths, import_skills=False)
        except ConfigError as exc:
            problems += exc.diagnostics
            continue
        ok.append(kind)
    return problems, ok
