"""`orchestrator validate`: check machines and scenarios, telling which is which. It imports no
code a file names (a scenario's `skills:` folders stay unimported: `scenario_skills.py`)."""

from __future__ import annotations

import re
from collections.abc import Sequence
from pathlib import Path

from ..exceptions import ConfigError
from .bundled import is_file, resolve_file
from .diagnostics import Diagnostic
from .limits import current_limits
from .load import load_machine, load_scenario
from .yamlio import load_yaml

__all__ = ["file_kind", "validate_paths"]


_TOP_KEY = re.compile(r"^([A-Za-z_][A-Za-z0-9_-]*)[ \t]*:", re.MULTILINE)
"""A key at the start of a line: the top-level keys of a block-style file."""


def _kind_of(keys: set[str] | None, path: Path) -> str:
    """Machine or scenario, from the file's top-level keys (None: it does not parse)."""
    if keys is None:
        return "machine" if "machine" in path.parts else "scenario"
    if "states" in keys:
        return "machine"
    if keys & {"scene", "robot", "machine"}:
        return "scenario"
    return "machine" if "initial" in keys else "scenario"


def _top_keys(path: Path) -> set[str] | None:
    """The top-level keys of `path`: read off the lines of a block-style file (no second full
    parse of a large file), else from its parsed YAML; None if it does not parse."""
    try:
        with path.open("rb") as f:
            head = f.read(current_limits().max_file_bytes + 1)
        keys = set(_TOP_KEY.findall(head.decode("utf-8", errors="replace")))
    except OSError:
        keys = set()
    if keys & {"states", "initial", "scene", "robot", "machine"}:
        return keys
    try:
        data = load_yaml(path).data
    except ConfigError:
        return None
    if not isinstance(data, dict):
        return set()
    return {k for k, v in data.items() if k != "machine" or isinstance(v, str)}


def file_kind(ref: str) -> tuple[str, str] | None:
    """(`machine` or `scenario`, the file or bundled name) of a reference; None if not found."""
    path = Path(ref)
    if is_file(path):
        return _kind_of(_top_keys(path), path), str(path)
    if resolve_file(ref, "scenarios") is not None:
        return "scenario", ref
    if resolve_file(ref, "machines") is not None:
        return "machine", ref
    return None


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
                load_scenario(kind[1], allow_paths=allow_paths, import_skills=False)
        except ConfigError as exc:
            problems += exc.diagnostics
            continue
        ok.append(kind)
    return problems, ok
