"""Perception: rendering backends (OpenGL, ray casting) and colour vision (detections).

Names are imported on first use: the language layer reads the named colours
(`perception.colours`) to check a scenario without loading OpenCV and MuJoCo.
"""

from __future__ import annotations

import importlib
from typing import Any

__all__ = [
    "NAMED_COLOURS",
    "BackendStatus",
    "CameraRig",
    "Detection",
    "Frame",
    "Intrinsics",
    "PerceptionError",
    "Renderer",
    "TrueObject",
    "backend_status",
    "classify_rgb",
    "detect_objects",
    "hsv_boxes",
    "match_detections",
    "open_renderer",
    "true_objects",
]

_WHERE = {
    "BackendStatus": "backends", "Renderer": "backends", "backend_status": "backends",
    "open_renderer": "backends", "NAMED_COLOURS": "colours", "classify_rgb": "colours",
    "hsv_boxes": "colours", "Detection": "detections", "detect_objects": "detections",
    "PerceptionError": "exceptions", "Frame": "frame", "Intrinsics": "frame",
    "CameraRig": "rig", "TrueObject": "truth", "match_detections": "truth",
    "true_objects": "truth",
}  # fmt: skip


def __getattr__(name: str) -> Any:
    if name not in _WHERE:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(importlib.import_module(f".{_WHERE[name]}", __name__), name)
