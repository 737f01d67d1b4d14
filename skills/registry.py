"""Skills by name. Every module of this package defining a Skill subclass registers it;
third-party packages add theirs through the `orchestrator.skills` entry-point group, and a
user's own folder of skill modules is added with `register_skill_path` (see `plugins`).
"""

from __future__ import annotations

import importlib
import pkgutil
from collections.abc import Sequence
from pathlib import Path

from orchestrator.exceptions import OrchestratorError

from .base import Skill
from .plugins import SkillLoadError, classes_in, entry_point_skills, load_skill_path

__all__ = [
    "BUNDLED",
    "SKILLS",
    "all_skills",
    "find_skill",
    "UnknownSkillError",
    "bundled_skill_names",
    "get_skill",
    "register_skill_path",
    "skill_names",
]

SKILLS: dict[str, type[Skill]] = {}
"""Skills imported so far, by name (a bundled skill is imported when first asked for)."""
_PKG = __name__.rsplit(".", 1)[0]
"""This package's import name (`orchestrator.skills`)."""
_NOT_SKILLS = {
    "base", "registry", "plugins", "ik", "ik_qp", "posture", "whole_body", "joint_limiter",
    "trajectory",
}  # fmt: skip
"""Modules of this package that define no skill and that discovery does not import: the
registry's own, and the IK's and the trajectories' machinery (mink, its QP, MuJoCo, Ruckig),
which a skill imports in the functions that run it. Listing the skills (and validating a
machine, which needs their `Params`) then loads no solver."""
BUNDLED: dict[str, str] = {
    "approach": "approach",
    "check_tool": "check_tool",
    "contact": "contact",
    "count": "count",
    "detect": "detect",
    "drive": "drive",
    "end_task": "end_task",
    "escape": "escape",
    "grasp": "grasp",
    "grasp_pose": "grasp_pose",
    "hold": "hold",
    "lookup": "lookup",
    "move": "move",
    "move_joints": "move_joints",
    "next_task": "next_task",
    "pass_parcel": "conveyor",
    "register": "register",
    "release": "release",
    "retract": "retract",
    "search": "search",
    "turn": "turn",
    "verify_grasp": "verify_grasp",
    "wait_for_parcel": "conveyor",
    "watch_force": "watch_force",
    "zero_sensor": "zero_sensor",
}
"""The bundled skills' names -> the module of this package that defines each. Validating a
machine imports only the modules of the skills it uses (all 25 cost ~85 ms of a 0.6 s
`orchestrator validate`). `tests/test_skill_index.py` holds this table equal to what importing
every module finds; a skill module missing from it is still found, by importing them all."""


class UnknownSkillError(OrchestratorError):
    """No skill of that name."""


_state = {"plugins": False, "all": False}
"""What has been imported: the entry points' skills; every module of this package."""


def _plugins() -> None:
    """Register the installed packages' skills (entry points, read once per process): a
    plugin's skill takes the name over from a bundled one, as it always has."""
    if _state["plugins"]:
        return
    _state["plugins"] = True
    for cls in entry_point_skills():
        SKILLS[cls.name] = cls


def _bundled_module(module: str) -> None:
    """Import one module of this package; its skills fill the names no plugin has taken."""
    for cls in classes_in(importlib.import_module(f"{_PKG}.{module}"), Skill):
        SKILLS.setdefault(cls.name, cls)


def _discover() -> None:
    """Import every module of this package (what listing every skill's declaration needs)."""
    _plugins()
    if _state["all"]:
        return
    _state["all"] = True
    for info in pkgutil.iter_modules([str(Path(__file__).parent)]):
        if info.name in _NOT_SKILLS or info.name.startswith("_"):
            continue
        _bundled_module(info.name)


def _registered(name: str) -> type[Skill] | None:
    """The skill registered as `name` (a plugin's, a local one or a bundled one), or None."""
    _plugins()
    if name in BUNDLED and name not in SKILLS:
        _bundled_module(BUNDLED[name])
    return SKILLS.get(name)


def find_skill(name: str) -> type[Skill] | None:
    """The skill class registered as `name`, importing only its module; None if there is none."""
    cls = _registered(name)
    if cls is None and not _state["all"]:
        _discover()  # a module this package has that `BUNDLED` does not name yet
        cls = SKILLS.get(name)
    return cls


def all_skills() -> dict[str, type[Skill]]:
    """Every available skill by name, each one's module imported (listings, schemas, docs)."""
    _discover()
    return SKILLS


def skill_names() -> list[str]:
    """Sorted names of every available skill (without importing the bundled ones)."""
    _plugins()
    return sorted(SKILLS.keys() | BUNDLED.keys())


def bundled_skill_names() -> list[str]:
    """Sorted names of the skills shipped with this package (no plugins, no local ones)."""
    _discover()
    return sorted(n for n, c in SKILLS.items() if c.__module__.startswith(_PKG + "."))


def register_skill_path(
    path: str | Path, require: bool = True, within: Sequence[Path] | None = None
) -> list[str]:
    """Register the skills of a local folder or `.py` file; returns their names.

    Args:
        path: The folder or file.
        require: A path without any skill is an error (False: it may hold only success checks).
        within: Directories it (and every module in it) must lie in, symlinks followed (a
            scenario's own tree and `--allow-path`); None: anywhere (`--skills`).

    Raises:
        SkillLoadError: The path cannot be loaded, lies outside `within`, or a skill's name is
            already taken by another skill (the message names both).
    """
    names = []
    for cls in load_skill_path(path, require, within):
        other = _registered(cls.name)
        if other is not None and other is not cls:
            raise SkillLoadError(
                f"{path}: skill name {cls.name!r} ({cls.__module__}.{cls.__qualname__}) is "
                f"already taken by {other.__module__}.{other.__qualname__}: rename it"
            )
        SKILLS[cls.name] = cls
        names.append(cls.name)
    return names


def get_skill(name: str) -> type[Skill]:
    """The skill class registered as `name`."""
    cls = find_skill(name)
    if cls is None:
        raise UnknownSkillError(f"unknown skill {name!r} (valid: {', '.join(skill_names())})")
    return cls
