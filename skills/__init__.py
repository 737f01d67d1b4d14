"""Atomic skills (installed as `orchestrator.skills`). Adding one is one new module here (and its
name in `registry.BUNDLED`, so that a machine using it imports that module only), or a module in
a folder of your own (`--skills PATH`, a scenario's `skills:`), or a plugin package
(`orchestrator.skills` entry points)."""

from .base import Skill, SkillParams
from .plugins import PLUGIN_WARNINGS, SkillLoadError
from .registry import (
    SKILLS,
    UnknownSkillError,
    all_skills,
    bundled_skill_names,
    find_skill,
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
    "all_skills",
    "bundled_skill_names",
    "find_skill",
    "get_skill",
    "register_skill_path",
    "skill_names",
]
