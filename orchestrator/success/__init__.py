"""Success checks: the criteria a scenario's `success:` names by `kind`, judged at the end of
a run. Adding one is a module here, a module in a folder of your own (a scenario's `skills:`,
`--skills`), or a plugin package (`orchestrator.success_checks` entry points)."""

from .base import SCENE_OBJECT, SCENE_TARGET, CheckParams, SuccessCheck, Verdict
from .params import blackboard_fields
from .registry import (
    CHECKS,
    UnknownCheckError,
    bundled_check_kinds,
    check_kinds,
    check_origin,
    get_check,
    register_check_path,
    register_plugin_path,
)

__all__ = [
    "CHECKS",
    "SCENE_OBJECT",
    "SCENE_TARGET",
    "CheckParams",
    "SuccessCheck",
    "UnknownCheckError",
    "Verdict",
    "blackboard_fields",
    "bundled_check_kinds",
    "check_kinds",
    "check_origin",
    "get_check",
    "register_check_path",
    "register_plugin_path",
]
