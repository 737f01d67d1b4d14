"""Skills from outside this package: installed plugins and a user's own folder of modules.

Two ways in, neither needs a change to the project:

* An installed package declares entry points in the `orchestrator.skills` group, each naming
  a `Skill` subclass (`wait = my_pkg.wait:Wait`). An entry point that fails to import, or
  that names something other than a Skill class, is skipped with a one-line warning
  (`PLUGIN_WARNINGS`) instead of breaking every command.
* A folder (or one `.py` file) of skill modules: a scenario's `skills: [my_skills]` or the
  CLI's `--skills PATH`. Every `Skill` subclass a module defines is registered by its `name`
  (and every success check by its `kind`: `orchestrator.success` reads the same modules).

Importing a module runs its code. A folder the user names on the command line is theirs to
trust; one a file names is kept to the places that file may read (`within`: its own tree and
`--allow-path` directories), every module checked after symlinks are followed, and listing
what a folder holds (`skill_files`) imports nothing. No error message quotes a module's text:
an import that fails is reported as its exception type and line only.
"""

from __future__ import annotations

import functools
import importlib.metadata
import importlib.util
import sys
import traceback
from collections.abc import Sequence
from pathlib import Path
from types import ModuleType
from typing import TypeVar

from orchestrator.exceptions import OrchestratorError

from .base import Skill

__all__ = [
    "PLUGIN_WARNINGS",
    "SkillLoadError",
    "SkillOutsideError",
    "classes_in",
    "entry_point_classes",
    "entry_point_skills",
    "is_loaded",
    "load_skill_path",
    "plugin_modules",
    "skill_files",
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


class SkillOutsideError(SkillLoadError):
    """A skill folder (or a module in it) lies outside the directories it may come from."""


@functools.cache
def _entry_points() -> importlib.metadata.EntryPoints | importlib.metadata.SelectableGroups:
    """Every installed entry point, read once per process: reading them opens the metadata of
    every installed distribution (~10 ms CPU with ~200 installed), and the skills and the
    success checks each look up their group (`validate` does both)."""
    return importlib.metadata.entry_points()


def entry_point_classes(group: str, base: type[T], what: str) -> list[type[T]]:
    """The `base` subclasses every installed entry point of `group` names (`wait =
    my_pkg.wait:Wait`). One that fails to import, or names something else, is skipped with a
    one-line warning in `PLUGIN_WARNINGS` naming it as a plugin `what` (`skill`)."""
    classes: list[type[T]] = []
    for ep in _entry_points().select(group=group):
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


def skill_files(path: str | Path, within: Sequence[Path] | None = None) -> list[Path]:
    """The modules a skill folder (or `.py` file) stands for, without importing any.

    Modules whose name starts with `_` are skipped.

    Args:
        path: The folder or file.
        within: Directories the folder and every module in it must lie in once symlinks are
            followed (None: anywhere, for a path the user named on the command line).

    Raises:
        SkillLoadError: The path does not exist, is neither a folder nor a `.py` file, or it
            (or a module in it) lies outside `within`.
    """
    root = Path(path).expanduser()
    try:
        real = root.resolve()
        exists = real.exists()
    except (OSError, RuntimeError, ValueError):  # a symlink loop, a name the system refuses
        raise SkillLoadError(f"{path}: cannot resolve the skill path") from None
    if within is not None:
        _check_inside(real, path, within)
    if not exists:
        raise SkillLoadError(f"{path}: no such skill file or folder")
    if real.is_dir():
        files = sorted(p for p in real.glob("*.py") if not p.name.startswith("_"))
    elif real.suffix == ".py":
        files = [real]
    else:
        raise SkillLoadError(f"{path}: not a folder nor a .py file")
    if within is not None:
        for file in files:  # a module may be a symlink out of an in-tree folder
            _check_inside(file.resolve(), file, within)
    return files


def _check_inside(real: Path, named: str | Path, within: Sequence[Path]) -> None:
    roots = [Path(r).resolve() for r in within]
    if not any(real == r or real.is_relative_to(r) for r in roots):
        where = ", ".join(str(r) for r in roots)
        raise SkillOutsideError(
            f"{named}: outside {where}, refused (a scenario loads skills only from its own "
            "directory tree: move the folder there, allow its directory with --allow-path DIR, "
            "or pass it yourself with --skills DIR)"
        )


def is_loaded(files: Sequence[Path]) -> bool:
    """Whether every module of `files` was imported already (e.g. from `--skills`)."""
    return all(f in _LOADED for f in files)


def plugin_modules(path: str | Path, within: Sequence[Path] | None = None) -> list[ModuleType]:
    """Import every module of a folder (or one `.py` file), once per process.

    A module may import anything it needs (`from orchestrator.skills import Skill,
    SkillParams`).

    Args:
        path: The folder or file.
        within: Directories it must lie in (see `skill_files`; None: anywhere).

    Raises:
        SkillLoadError: See `skill_files`; or a module fails to import (the message has the
            file, line and exception type).
    """
    files = skill_files(path, within)
    for file in files:
        if file not in _LOADED:
            _LOADED[file] = _import(file)
    return [_LOADED[file] for file in files]


def load_skill_path(
    path: str | Path, require: bool = True, within: Sequence[Path] | None = None
) -> list[type[Skill]]:
    """Import every module of a folder (or one `.py` file) and return its skills.

    Args:
        path: The folder or file.
        require: A path without any skill is an error (False: it may hold only success
            checks).
        within: Directories it must lie in (see `skill_files`; None: anywhere).

    Raises:
        SkillLoadError: The path cannot be imported (`plugin_modules`), or it defines no
            skill at all and `require` is set.
    """
    modules = plugin_modules(path, within)
    classes = [cls for module in modules for cls in classes_in(module, Skill)]
    if not classes and require:
        raise SkillLoadError(
            f"{path}: defines no skill (a subclass of orchestrator.skills.Skill with a `name`)"
        )
    return classes


def _import(file: Path) -> ModuleType:
    import hashlib  # here: only a local skill folder needs it (~3 ms of every command)

    digest = hashlib.sha1(str(file).encode()).hexdigest()[:8]
    mod_name = f"{LOCAL_PREFIX}{file.stem}_{digest}"
    spec = importlib.util.spec_from_file_location(mod_name, file)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[mod_name] = module
    try:
        spec.loader.exec_module(module)
    except (Exception, SystemExit) as exc:  # a module that calls exit() is a failed import
        del sys.modules[mod_name]
        frames = [f for f in traceback.extract_tb(exc.__traceback__) if f.filename == str(file)]
        line = f":{frames[-1].lineno}" if frames else ""
        if isinstance(exc, SyntaxError) and exc.lineno:
            line = f":{exc.lineno}"
        # the exception's text is not shown: it may quote the file (`name 'hunter2' is not
        # defined`), and the file may be anything a scenario names
        raise SkillLoadError(
            f"{file}{line}: the skill module fails to import: {type(exc).__name__} (its message "
            f"is not shown; `python {file}` shows it)"
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
