"""The body: the MuJoCo world built from a scenario (robot, scene, randomization), poses.

Names are imported on first use: importing a submodule (`orchestrator.world.native`, which
`orchestrator --version` reads) does not load MuJoCo, pinocchio and the robots.
"""

from __future__ import annotations

import importlib
from typing import Any

__all__ = [
    "ObjectHandle",
    "PhantomHandle",
    "PlannedPath",
    "Pose",
    "World",
    "as_index",
    "quat_from_yaw",
    "robot_only_model",
    "yaw_of",
]

_WHERE = {
    "PlannedPath": "path", "PhantomHandle": "phantom", "Pose": "pose", "quat_from_yaw": "pose",
    "yaw_of": "pose", "ObjectHandle": "world", "World": "world", "as_index": "indexing",
    "robot_only_model": "world",
}  # fmt: skip


def __getattr__(name: str) -> Any:
    if name not in _WHERE:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(importlib.import_module(f".{_WHERE[name]}", __name__), name)
