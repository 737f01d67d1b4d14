"""Skills from outside this package: installed plugins and a user's own folder of modules.

Two ways in, neither needs a change to the project:

* An installed package declares entry points in the `orchestrator.skills` group, each naming
  a `Skill` subclass (`wait = my_pkg.wait:Wait`). An entry point that fails to import, or
  that names something other than a Skill class, is skipped with a one-line warning
  (`PLUGIN_WARNINGS`) instead of breaking every command.
* A folder (or one `.py` file) of skill modules: a scenario's `skills: [my_skills]` or the
  CLI's `--skills PATH`. Every `Skill` subclass a module defines is registered by its `name`
  (and every success check by its `kind`: `orchestrator.success` reads the same modules).
"""

from __future__ import annotations

import hashlib
import importlib.metadata
import importlib.util
import sys
import traceback
from pathlib import Path
from types import ModuleType
from typing import TypeVar

from orchestrator.exceptions import OrchestratorError

from .base import Skill

__all__ = [
    "PLUGIN_WARNINGS",
    "SkillLoadError",
    "classes_in",
    "entry_point_classes",
    "entry_point_skills",
    "load_skill_path",
    "plugin_modules",
    "skill_origin",
]

T = TypeVar("T")
GROUP = "orchestrator.skills"
"""The entry-point group plugin packages declare their skills in."""
PLUGIN_WARNINGS: list[str] = []
"""One line per plugin entry point that was skipped, and why (the CLI prints them)."""
_LOADED: dict[Path, ModuleType] = {}
"""Plugin files already imported (a file is imported once per process) -> their modules."""
LOCAL_PREFIX = "orchestrator_local_skills."
"""Modules of a local folder are imported under this name (and a hash of their path)."""


class SkillLoadError(OrchestratorError):
    """A local skill file or folder cannot be loaded (missing, fails to import, no skill)."""


def entry_point_classes(group: str, base: type[T], what: str) -> list[type[T]]:
    """The `base` subclasses every installed entry point of `group` names (`wait =
    my_pkg.wait:Wait`). One that fails to import, or names something else, is skipped with a
    one-line warning in `PLUGIN_WARNINGS` naming it as a plugin `what` (`skill`)."""
    classes: list[type[T]] = []
    for ep in importlib.metadata.entry_points(group=group):
        where = f"plugin {what} {ep.name!r} ({ep.value}"
        dist = getattr(ep, "dist", None)
        where += f", from {dist.name})" if dist is not None else ")"
        try:
            obj = ep.load()
        except Exception as exc:  # any error in a third-party import: report, go on
            PLUGIN_WARNINGS.append(
                f"{where} failed to import and is skipped: {type(exc).__name__}: {exc}"
            )
            continue
        if isinstance(obj, type) and issubclass(obj, base):
            classes.append(obj)
        else:
            kind = "a module" if type(obj).__name__ == "module" else type(obj).__name__
            PLUGIN_WARNINGS.append(
                f"{where} names {kind}, not a {base.__name__} class, and is skipped: write "
                f"'{ep.value.split(':')[0]}:ClassName'"
            )
    return classes


def entry_point_skills() -> list[type[Skill]]:
    """The Skill classes of every installed `orchestrator.skills` entry point."""
    return entry_point_classes(GROUP, Skill, "skill")


def classes_in(module: ModuleType, base: type[T]) -> list[type[T]]:
    """The concrete `base` subclasses `module` defines (not those it imports)."""
    return [
        obj
        for obj in vars(module).values()
        if isinstance(obj, type)
        and issubclass(obj, base)
        and obj is not base
        and obj.__module__ == module.__name__
        and not getattr(obj, "__abstractmethods__", None)
    ]


def plugin_modules(path: str | Path) -> list[ModuleType]:
    """Import every module of a folder (or one `.py` file), once per process.

    Modules whose name starts with `_` are skipped. A module may import anything it needs
    (`from orchestrator.skills import Skill, SkillParams`).

    Raises:
        SkillLoadError: The path does not exist, or a module fails to import (the message has
            the file, line and error).
    """
    root = Path(path).expanduser().resolve()
    if not root.exists():
        raise SkillLoadError(f"{path}: no such skill file or folder")
    if root.is_dir():
        files = sorted(p for p in root.glob("*.py") if not p.name.startswith("_"))
    elif root.suffix == ".py":
        files = [root]
    else:
        raise SkillLoadError(f"{path}: not a folder nor a .py file")
    for file in files:
        if file not in _LOADED:
            _LOADED[file] = _import(file)
    return [_LOADED[file] for file in files]


def load_skill_path(path: str | Path, require: bool = True) -> list[type[Skill]]:
    """Import every module of a folder (or one `.py` file) and return its skills.

    Args:
        path: The folder or file.
        require: A path without any skill is an error (False: it may hold only success
            checks).

    Raises:
        SkillLoadError: The path cannot be imported (`plugin_modules`), or it defines no
            skill at all and `require` is set.
    """
    classes = [cls for module in plugin_modules(path) for cls in classes_in(module, Skill)]
    if not classes and require:
        raise SkillLoadError(
            f"{path}: defines no skill (a subclass of orchestrator.skills.Skill with a `name`)"
        )
    return classes


def _import(file: Path) -> ModuleType:
    digest = hashlib.sha1(str(file).encode()).hexdigest()[:8]
    mod_name = f"{LOCAL_PREFIX}{file.stem}_{digest}"
    spec = importlib.util.spec_from_file_location(mod_name, file)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[mod_name] = module
    try:
        spec.loader.exec_module(module)
    except Exception as exc:
        del sys.modules[mod_name]
        frames = [f for f in traceback.extract_tb(exc.__traceback__) if f.filename == str(file)]
        line = f":{frames[-1].lineno}" if frames else ""
        if isinstance(exc, SyntaxError) and exc.lineno:
            line = f":{exc.lineno}"
        raise SkillLoadError(
            f"{file}{line}: the skill module fails to import: {type(exc).__name__}: {exc}"
        ) from None
    return module


def skill_origin(cls: type[Skill]) -> str:
    """Where a skill comes from: `bundled`, a plugin's module, or a local file."""
    module = cls.__module__
    if module.startswith("orchestrator.skills."):
        return "bundled"
    if module.startswith(LOCAL_PREFIX):
        return str(sys.modules[module].__file__)
    return f"plugin {module}"
