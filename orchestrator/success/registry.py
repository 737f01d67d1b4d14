"""Success checks by `kind`, registered like skills.

Every module of this package defining a SuccessCheck subclass registers it; an installed
package adds its own through the `orchestrator.success_checks` entry-point group
(`aligned = "my_pkg.aligned:Aligned"`); a folder of your own modules is read by
`register_plugin_path` — the same folders as skills (a scenario's `skills:`, `--skills`), so
one folder may hold both.
"""

from __future__ import annotations

import importlib
import pkgutil
import sys
from collections.abc import Sequence
from pathlib import Path

from ..exceptions import OrchestratorError
from ..skills import SkillLoadError, register_skill_path
from ..skills.plugins import LOCAL_PREFIX, classes_in, entry_point_classes, plugin_modules
from .base import SuccessCheck

__all__ = [
    "CHECKS",
    "GROUP",
    "UnknownCheckError",
    "bundled_check_kinds",
    "check_kinds",
    "check_origin",
    "get_check",
    "register_check_path",
    "register_plugin_path",
]

GROUP = "orchestrator.success_checks"
"""The entry-point group plugin packages declare their success checks in."""
CHECKS: dict[str, type[SuccessCheck]] = {}
_PKG = __name__.rsplit(".", 1)[0]
"""This package's import name (`orchestrator.success`)."""
_NOT_CHECKS = {"base", "registry", "geometry"}


class UnknownCheckError(OrchestratorError):
    """No success check of that kind."""


def _discover() -> None:
    if CHECKS:
        return
    classes: list[type[SuccessCheck]] = []
    for info in pkgutil.iter_modules([str(Path(__file__).parent)]):
        if info.name not in _NOT_CHECKS and not info.name.startswith("_"):
            classes += classes_in(importlib.import_module(f"{_PKG}.{info.name}"), SuccessCheck)
    classes += entry_point_classes(GROUP, SuccessCheck, "success check")
    for cls in classes:
        CHECKS[cls.kind] = cls


def check_kinds() -> list[str]:
    """Sorted kinds of every available success check."""
    _discover()
    return sorted(CHECKS)


def bundled_check_kinds() -> list[str]:
    """Sorted kinds of the checks shipped with this package (no plugins, no local ones)."""
    _discover()
    return sorted(k for k, c in CHECKS.items() if c.__module__.startswith(_PKG + "."))


def get_check(kind: str) -> type[SuccessCheck]:
    """The success check registered as `kind`."""
    _discover()
    try:
        return CHECKS[kind]
    except KeyError:
        raise UnknownCheckError(
            f"unknown success check kind {kind!r} (valid: {', '.join(sorted(CHECKS))})"
        ) from None


def register_check_path(
    path: str | Path, require: bool = True, within: Sequence[Path] | None = None
) -> list[str]:
    """Register the success checks of a local folder or `.py` file; returns their kinds.

    Args:
        path: The folder or file.
        require: A path without any check is an error.
        within: Directories it must lie in (`orchestrator.skills.plugins.skill_files`; None:
            anywhere, for a path the user named).

    Raises:
        SkillLoadError: The path cannot be loaded, it defines no check and `require` is set,
            or a kind is already taken by another check (the message names both).
    """
    _discover()
    kinds = []
    for module in plugin_modules(path, within):
        for cls in classes_in(module, SuccessCheck):
            other = CHECKS.get(cls.kind)
            if other is not None and other is not cls:
                raise SkillLoadError(
                    f"{path}: success check kind {cls.kind!r} ({cls.__module__}."
                    f"{cls.__qualname__}) is already taken by {other.__module__}."
                    f"{other.__qualname__}: rename it"
                )
            CHECKS[cls.kind] = cls
            kinds.append(cls.kind)
    if not kinds and require:
        raise SkillLoadError(f"{path}: defines no success check (a SuccessCheck with a `kind`)")
    return kinds


def register_plugin_path(path: str | Path, within: Sequence[Path] | None = None) -> list[str]:
    """Register the skills and success checks of a local folder or `.py` file (a scenario's
    `skills:`, `--skills`); returns their names.

    Args:
        path: The folder or file.
        within: Directories it (and every module in it) must lie in, symlinks followed (a
            scenario's own tree and `--allow-path`); None: anywhere (`--skills`).

    Raises:
        SkillLoadError: The path cannot be loaded, lies outside `within`, defines neither, or
            a name is taken.
    """
    names = register_skill_path(path, require=False, within=within) + register_check_path(
        path, require=False, within=within
    )
    if not names:
        raise SkillLoadError(
            f"{path}: defines no skill (a subclass of orchestrator.skills.Skill with a `name`) "
            "and no success check (a subclass of orchestrator.success.SuccessCheck with a `kind`)"
        )
    return names


def check_origin(cls: type[SuccessCheck]) -> str:
    """Where a check comes from: `bundled`, a plugin's module, or a local file."""
    module = cls.__module__
    if module.startswith(_PKG + "."):
        return "bundled"
    if module.startswith(LOCAL_PREFIX):
        return str(sys.modules[module].__file__)
    return f"plugin {module}"
