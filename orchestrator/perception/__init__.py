"""Perception: rendering backends (OpenGL, ray casting) and colour vision (detections)."""

from .backends import BackendStatus, Renderer, backend_status, open_renderer
from .colours import NAMED_COLOURS, classify_rgb, hsv_boxes
from .exceptions import PerceptionError
from .frame import Frame, Intrinsics

__all__ = [
    "NAMED_COLOURS",
    "BackendStatus",
    "Frame",
    "Intrinsics",
    "PerceptionError",
    "Renderer",
    "backend_status",
    "classify_rgb",
    "hsv_boxes",
    "open_renderer",
]
