"""Skills by name. Every module of this package defining a Skill subclass registers it;
third-party packages add theirs through the `orchestrator.skills` entry-point group.
"""

from __future__ import annotations

import importlib
import importlib.metadata
import pkgutil
from pathlib import Path

from orchestrator.exceptions import OrchestratorError

from .base import Skill

__all__ = ["SKILLS", "UnknownSkillError", "get_skill", "skill_names"]

SKILLS: dict[str, type[Skill]] = {}
_NOT_SKILLS = {"base", "registry", "ik", "joint_limiter", "trajectory"}


class UnknownSkillError(OrchestratorError):
    """No skill of that name."""


def _discover() -> None:
    if SKILLS:
        return
    pkg_name = __name__.rsplit(".", 1)[0]  # this package, without importing it from itself
    pkg_path = [str(Path(__file__).parent)]
    classes: list[type[Skill]] = []
    for info in pkgutil.iter_modules(pkg_path):
        if info.name in _NOT_SKILLS or info.name.startswith("_"):
            continue
        module = importlib.import_module(f"{pkg_name}.{info.name}")
        for obj in vars(module).values():
            if isinstance(obj, type) and issubclass(obj, Skill) and obj is not Skill:
                if obj.__module__ == module.__name__ and not getattr(
                    obj, "__abstractmethods__", None
                ):
                    classes.append(obj)
    for ep in importlib.metadata.entry_points(group="orchestrator.skills"):
        obj = ep.load()
        if isinstance(obj, type) and issubclass(obj, Skill):
            classes.append(obj)
    for cls in classes:
        SKILLS[cls.name] = cls


def skill_names() -> list[str]:
    """Sorted names of every available skill."""
    _discover()
    return sorted(SKILLS)


def get_skill(name: str) -> type[Skill]:
    """The skill class registered as `name`."""
    _discover()
    try:
        return SKILLS[name]
    except KeyError:
        raise UnknownSkillError(
            f"unknown skill {name!r} (valid: {', '.join(sorted(SKILLS))})"
        ) from None
