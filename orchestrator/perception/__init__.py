"""Perception: rendering backends (OpenGL, ray casting) and colour vision (detections)."""

from .backends import BackendStatus, Renderer, backend_status, open_renderer
from .colours import NAMED_COLOURS, classify_rgb, hsv_boxes
from .detections import Detection, detect_objects
from .exceptions import PerceptionError
from .frame import Frame, Intrinsics
from .rig import CameraRig
from .truth import TrueObject, match_detections, true_objects

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
