"""Bundled machines and scenarios, found by name; files named on the command line."""

from __future__ import annotations

import re
from importlib import resources
from pathlib import Path

__all__ = [
    "BUNDLED_NAME",
    "bundled_folder",
    "bundled_names",
    "bundled_path",
    "is_file",
    "resolve_file",
]

BUNDLED_NAME = re.compile(r"^[A-Za-z0-9_][A-Za-z0-9_.-]{0,127}$")
"""What a bundled name may look like: no `/`, no `..`, nothing that leaves the folder."""


def bundled_folder(kind: str) -> Path:
    """The folder of the bundled `machines` or `scenarios`."""
    return Path(str(resources.files(f"orchestrator.{kind}")))


def bundled_names(kind: str) -> list[str]:
    """Names of the bundled `machines` or `scenarios`."""
    return sorted(p.stem for p in bundled_folder(kind).glob("*.yaml"))


def bundled_path(kind: str, name: str) -> Path | None:
    """Path of a bundled file by name (with or without `.yaml`), or None."""
    if not BUNDLED_NAME.match(name) or ".." in name:
        return None
    stem = name[:-5] if name.endswith(".yaml") else name
    path = bundled_folder(kind) / f"{stem}.yaml"
    return path if path.is_file() else None


def is_file(path: Path) -> bool:
    """`path.is_file()`, False for names the system refuses (too long, a NUL byte)."""
    try:
        return path.is_file()
    except (OSError, ValueError):
        return False


def resolve_file(ref: str, kind: str, base_dir: Path | None = None) -> Path | None:
    """A reference the user typed -> file: relative to `base_dir`, then as given, then a
    bundled name. (Includes inside files go through `includes.resolve_include`, which also
    keeps them inside the allowed directories.)"""
    candidates = []
    if base_dir is not None:
        candidates.append(base_dir / ref)
    candidates.append(Path(ref))
    for c in candidates:
        if is_file(c):
            return c
    return bundled_path(kind, ref)
