"""Atomic skills (installed as `orchestrator.skills`). Adding one is one new module here, or a
module in a folder of your own (`--skills PATH`, a scenario's `skills:`), or a plugin package
(`orchestrator.skills` entry points)."""

from .base import Skill, SkillParams
from .plugins import PLUGIN_WARNINGS, SkillLoadError
from .registry import (
    SKILLS,
    UnknownSkillError,
    bundled_skill_names,
    get_skill,
    register_skill_path,
    skill_names,
)

__all__ = [
    "PLUGIN_WARNINGS",
    "SKILLS",
    "Skill",
    "SkillLoadError",
    "SkillParams",
    "UnknownSkillError",
    "bundled_skill_names",
    "get_skill",
    "register_skill_path",
    "skill_names",
]
