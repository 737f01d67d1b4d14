"""Where a motion goes: absolute poses, named scene objects and markers, blackboard poses."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np
from pydantic import ValidationError

from orchestrator.exceptions import SkillError
from orchestrator.world.pose import Pose

if TYPE_CHECKING:
    from orchestrator.engine.context import Context

__all__ = ["DOWN", "resolve_target", "rot_down", "yaw_of_rot"]

DOWN = np.diag([1.0, -1.0, -1.0])
"""TCP orientation pointing straight down, fingers closing along world y (yaw 0)."""


def rot_down(yaw: float) -> np.ndarray:
    """TCP pointing down, rotated about world z by `yaw` [rad]."""
    c, s = math.cos(yaw), math.sin(yaw)
    rz = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    return rz @ DOWN


def yaw_of_rot(rot: np.ndarray) -> float:
    """Heading [rad] of a rotation's x axis in the world xy plane."""
    return math.atan2(rot[1, 0], rot[0, 0])


def resolve_target(ctx: Context, target: Any) -> Pose:
    """A world pose from a name (object or marker), a Pose / `{pos, quat}`, or `[x, y, z]`."""
    if isinstance(target, str):
        if target in ctx.world.objects:
            return ctx.object_pose(target)
        if target in ctx.world.markers:
            return Pose(pos=ctx.world.markers[target].tolist())
        valid = sorted([*ctx.world.objects, *ctx.world.markers])
        raise SkillError(f"unknown target {target!r} (valid: {', '.join(valid)})")
    try:
        return Pose.coerce(target)
    except ValidationError as exc:
        first = exc.errors()[0]
        where = ".".join(str(p) for p in first["loc"])
        raise SkillError(f"cannot read a pose from {target!r}: {where}: {first['msg']}") from None
    except (ValueError, TypeError) as exc:
        raise SkillError(f"cannot read a pose from {target!r}: {exc}") from None
