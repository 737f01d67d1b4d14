"""Camera frames in a recording: each camera as a pinhole in the 3D scene, with the RGB, depth
and segmentation images a perception skill looked at and its detections as labelled boxes.

The RGB image is stored exactly as rendered (lossless PNG); depth in millimetres (uint16);
segmentation as geom id + 1 (uint16). The default layout shows the RGB image with the boxes
over it; depth and segmentation are layers the reader turns on (blueprint.py).

Logged only at the ticks a skill captured a frame (`Context.camera_shots`), never per tick.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import cv2
import numpy as np
import rerun as rr

from .paths import CAMERAS, SIM_TIME, TICK

if TYPE_CHECKING:
    from ..engine.context import Context
    from ..perception.detections import Detection
    from ..perception.frame import Frame

__all__ = ["CameraShots", "camera_path", "contrasting"]


def camera_path(name: str) -> str:
    """Entity path of a camera: its pose and pinhole; images and boxes are its children."""
    return f"{CAMERAS}/{name}"


class CameraShots:
    """Takes the frames skills captured off the context; logs them once the stream is open."""

    def __init__(self, ctx: Context) -> None:
        self._ctx = ctx
        self._pending: list[tuple[int, float, Frame, list[Detection]]] = []
        if ctx.scenario.cameras:
            ctx.cameras.segmentation = True  # a recording shows the segmentation image too
            ctx.keep_camera_shots = True

    def sample(self) -> None:
        """Move the frames captured since the last call into the buffer."""
        shots = self._ctx.camera_shots
        if shots:
            self._pending.extend(shots)
            shots.clear()

    def log(self, rec: rr.RecordingStream) -> None:
        """Log the buffered frames on `rec` at their ticks and simulated times."""
        if not self._pending:
            return
        rec.set_log_time_enabled(False)  # wall-clock stamps would make recordings differ
        for tick, t, frame, found in self._pending:
            rec.set_time(TICK, sequence=tick)
            rec.set_time(SIM_TIME, duration=np.timedelta64(int(round(t * 1e9)), "ns"))
            for path, archetype in _archetypes(frame, found):
                rec.log(path, archetype)
        rec.reset_time()
        self._pending.clear()


_WHITE, _BLACK = 0xFFFFFFFF, 0x000000FF


def _luminance(rgb: np.ndarray) -> float:
    """Relative luminance (WCAG) of an sRGB colour with channels in [0, 1]."""
    c = np.where(rgb <= 0.04045, rgb / 12.92, ((rgb + 0.055) / 1.055) ** 2.4)
    return float(c @ np.array([0.2126, 0.7152, 0.0722]))


def contrasting(rgb: np.ndarray, bbox: tuple[int, int, int, int]) -> int:
    """The colour of a detection's box and label: white or black, whichever contrasts more
    (WCAG contrast ratio) with the mean colour of the image inside the box (the object), so
    the label reads on a red parcel as on a yellow cube (0xRRGGBBAA)."""
    x, y, w, h = bbox
    patch = rgb[max(y, 0) : max(y + h, y + 1), max(x, 0) : max(x + w, x + 1)]
    if patch.size == 0:
        return _WHITE
    lum = _luminance(patch.reshape(-1, 3).mean(axis=0) / 255.0)
    return _WHITE if (1.05) / (lum + 0.05) >= (lum + 0.05) / 0.05 else _BLACK


def _png(bgr: np.ndarray) -> bytes:
    """A lossless PNG of an 8-bit BGR image (the RGB image exactly as rendered, ~3x smaller)."""
    ok, data = cv2.imencode(".png", bgr, [cv2.IMWRITE_PNG_COMPRESSION, 1])
    if not ok:  # pragma: no cover - OpenCV encodes any uint8 image
        raise ValueError("PNG encoding failed")
    return data.tobytes()


def _millimetres(depth_m: np.ndarray) -> np.ndarray:
    """Depth [m] as uint16 millimetres (0: nothing hit), half the size of float32."""
    return np.clip(np.rint(depth_m * 1000.0), 0, np.iinfo(np.uint16).max).astype(np.uint16)


def _archetypes(frame: Frame, found: list[Detection]) -> list[tuple[str, Any]]:
    k = frame.intrinsics
    path = camera_path(frame.camera)
    out: list[tuple[str, Any]] = [
        (path, rr.Transform3D(translation=frame.pos, mat3x3=frame.rot)),
        (
            path,
            rr.Pinhole(
                image_from_camera=k.matrix(),
                resolution=[k.width, k.height],
                camera_xyz=rr.ViewCoordinates.RUB,  # MuJoCo's camera: x right, y up, z back
                image_plane_distance=0.1,
            ),
        ),
        (
            f"{path}/rgb",
            rr.EncodedImage(contents=_png(frame.rgb[:, :, ::-1]), media_type="image/png"),
        ),
        (f"{path}/depth", rr.DepthImage(_millimetres(frame.depth), meter=1000.0)),
    ]
    if frame.seg is not None:
        seg = np.clip(frame.seg + 1, 0, np.iinfo(np.uint16).max).astype(np.uint16)
        out.append((f"{path}/segmentation", rr.SegmentationImage(seg)))
    out.append(
        (
            f"{path}/detections",
            rr.Boxes2D(
                array=np.array([d.bbox for d in found], float).reshape(-1, 4),
                array_format=rr.Box2DFormat.XYWH,
                labels=[f"{d.cls} {d.confidence:.2f}" for d in found],
                colors=np.array([contrasting(frame.rgb, d.bbox) for d in found], np.uint32),
            ),
        )
    )
    return out
