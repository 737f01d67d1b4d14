"""A move's motion as data for its snapshot state (engine/snapshot): its path and dry runs,
and the same objects made again from that data."""

from __future__ import annotations

from typing import Any

import numpy as np

from .blended_path import BlendedPath
from .dry_run import DryRun
from .plain_state import plain_state, restore_plain
from .trajectory import CartesianLine, Profile

__all__ = ["PATHS", "dry_from", "path_from", "path_state"]

PATHS: dict[str, type] = {"CartesianLine": CartesianLine, "BlendedPath": BlendedPath}
"""The paths a move follows, by their name in its snapshot state."""


def path_state(path: Any) -> dict[str, Any]:
    """A path's data: its plain attributes, its start orientation (a quaternion) and the
    arguments of its timing profile (made again from them)."""
    state: dict[str, Any] = plain_state(path)
    state["$rot0"] = path.rot0.wxyz.copy()
    profile = getattr(path, "profile", None)
    if profile is not None:
        state["$profile"] = [None if a is None else float(a) for a in profile._args]
    return state


def path_from(cls: type, state: dict[str, Any]) -> Any:
    import mink

    state = dict(state)
    path = cls.__new__(cls)
    rot0, profile = state.pop("$rot0"), state.pop("$profile", None)
    restore_plain(path, state)
    path.rot0 = mink.SO3(wxyz=np.array(rot0, dtype=float))
    if profile is not None:
        path.profile = Profile(*profile)
    return path


def dry_from(fields: dict[str, Any]) -> DryRun:
    fields = dict(fields)
    fields["torque_ratio"] = tuple(fields["torque_ratio"])
    return DryRun(**fields)
