"""Success checks by `kind`, registered like skills.

Every module of this package defining a SuccessCheck subclass registers it; an installed
package adds its own through the `orchestrator.success_checks` entry-point group
(`aligned = "my_pkg.aligned:Aligned"`); a folder of your own modules is read by
`register_plugin_path` — the same folders as skills (a scenario's `skills:`, `--skills`), so
one folder may hold both.
"""

from __future__ import annotations

import importlib
import importlib.metadata
import pkgutil
import sys
from pathlib import Path
from types import ModuleType

from ..exceptions import OrchestratorError
from ..skills import PLUGIN_WARNINGS, SkillLoadError, register_skill_path
from ..skills.plugins import LOCAL_PREFIX, plugin_modules
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


def _checks_of(module: ModuleType) -> list[type[SuccessCheck]]:
    return [
        obj
        for obj in vars(module).values()
        if isinstance(obj, type)
        and issubclass(obj, SuccessCheck)
        and obj.__module__ == module.__name__
        and not getattr(obj, "__abstractmethods__", None)
    ]


def _discover() -> None:
    if CHECKS:
        return
    classes: list[type[SuccessCheck]] = []
    for info in pkgutil.iter_modules([str(Path(__file__).parent)]):
        if info.name not in _NOT_CHECKS and not info.name.startswith("_"):
            classes += _checks_of(importlib.import_module(f"{_PKG}.{info.name}"))
    classes += _entry_point_checks()
    for cls in classes:
        CHECKS[cls.kind] = cls


def _entry_point_checks() -> list[type[SuccessCheck]]:
    """The checks of every installed entry point; a broken one is skipped with a warning."""
    classes: list[type[SuccessCheck]] = []
    for ep in importlib.metadata.entry_points(group=GROUP):
        dist = getattr(ep, "dist", None)
        where = f"plugin success check {ep.name!r} ({ep.value}"
        where += f", from {dist.name})" if dist is not None else ")"
        try:
            obj = ep.load()
        except Exception as exc:  # any error in a third-party import: report, go on
            PLUGIN_WARNINGS.append(
                f"{where} failed to import and is skipped: {type(exc).__name__}: {exc}"
            )
            continue
        if isinstance(obj, type) and issubclass(obj, SuccessCheck):
            classes.append(obj)
        else:
            PLUGIN_WARNINGS.append(
                f"{where} names {type(obj).__name__}, not a SuccessCheck class, and is "
                f"skipped: write '{ep.value.split(':')[0]}:ClassName'"
            )
    return classes


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


def register_check_path(path: str | Path, require: bool = True) -> list[str]:
    """Register the success checks of a local folder or `.py` file; returns their kinds.

    Raises:
        SkillLoadError: The path cannot be loaded, it defines no check and `require` is set,
            or a kind is already taken by another check (the message names both).
    """
    _discover()
    kinds = []
    for module in plugin_modules(path):
        for cls in _checks_of(module):
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


def register_plugin_path(path: str | Path) -> list[str]:
    """Register the skills and success checks of a local folder or `.py` file (a scenario's
    `skills:`, `--skills`); returns their names.

    Raises:
        SkillLoadError: The path cannot be loaded, defines neither, or a name is taken.
    """
    names = register_skill_path(path, require=False) + register_check_path(path, require=False)
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
