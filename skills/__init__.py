"""Atomic skills (installed as `orchestrator.skills`). Adding one is one new module here."""

from .base import Skill, SkillParams
from .registry import SKILLS, UnknownSkillError, get_skill, skill_names

__all__ = ["SKILLS", "Skill", "SkillParams", "UnknownSkillError", "get_skill", "skill_names"]
