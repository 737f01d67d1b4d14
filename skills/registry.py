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
    "SKILLS",
    "UnknownSkillError",
    "bundled_skill_names",
    "get_skill",
    "register_skill_path",
    "skill_names",
]

SKILLS: dict[str, type[Skill]] = {}
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


class UnknownSkillError(OrchestratorError):
    """No skill of that name."""


def _discover() -> None:
    if SKILLS:
        return
    pkg_path = [str(Path(__file__).parent)]
    classes: list[type[Skill]] = []
    for info in pkgutil.iter_modules(pkg_path):
        if info.name in _NOT_SKILLS or info.name.startswith("_"):
            continue
        classes += classes_in(importlib.import_module(f"{_PKG}.{info.name}"), Skill)
    classes += entry_point_skills()
    for cls in classes:
        SKILLS[cls.name] = cls


def skill_names() -> list[str]:
    """Sorted names of every available skill."""
    _discover()
    return sorted(SKILLS)


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
    _discover()
    names = []
    for cls in load_skill_path(path, require, within):
        other = SKILLS.get(cls.name)
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
    _discover()
    try:
        return SKILLS[name]
    except KeyError:
        raise UnknownSkillError(
            f"unknown skill {name!r} (valid: {', '.join(sorted(SKILLS))})"
        ) from None
