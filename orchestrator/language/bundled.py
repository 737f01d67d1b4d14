"""Bundled machines and scenarios, found by name."""

from __future__ import annotations

from importlib import resources
from pathlib import Path

__all__ = ["bundled_names", "bundled_path", "resolve_file"]


def _folder(kind: str) -> Path:
    return Path(str(resources.files(f"orchestrator.{kind}")))


def bundled_names(kind: str) -> list[str]:
    """Names of the bundled `machines` or `scenarios`."""
    return sorted(p.stem for p in _folder(kind).glob("*.yaml"))


def bundled_path(kind: str, name: str) -> Path | None:
    """Path of a bundled file by name (with or without `.yaml`), or None."""
    stem = name[:-5] if name.endswith(".yaml") else name
    path = _folder(kind) / f"{stem}.yaml"
    return path if path.is_file() else None


def resolve_file(ref: str, kind: str, base_dir: Path | None = None) -> Path | None:
    """A user reference -> file: relative to `base_dir`, then as given, then a bundled name."""
    candidates = []
    if base_dir is not None:
        candidates.append(base_dir / ref)
    candidates.append(Path(ref))
    for c in candidates:
        if c.is_file():
            return c
    return bundled_path(kind, Path(ref).name if "/" not in ref else ref)
