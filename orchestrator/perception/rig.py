"""The cameras of one episode: a renderer opened on first use, and the sensor's noise.

Rendering happens only when a skill asks for a frame (`detect`, at a control tick), never on
the physics step. Image noise is drawn from its own random stream (seed, frame count), so a
run is reproducible bit for bit.
"""

from __future__ import annotations

import functools
import statistics
from typing import TYPE_CHECKING

import mujoco
import numpy as np

from ..world.random_streams import stream
from .backends import Renderer, open_renderer
from .exceptions import PerceptionError
from .frame import Frame, Intrinsics

if TYPE_CHECKING:
    from ..language.scenario import Scenario

__all__ = ["CameraRig"]


@functools.cache
def _normal_quantiles() -> np.ndarray:
    """The standard normal's quantiles at the centres of 65536 equal probability bins."""
    inv = statistics.NormalDist().inv_cdf
    return np.array([inv((i + 0.5) / 65536) for i in range(65536)], np.float32)


@functools.lru_cache(maxsize=8)
def _rounded_normal(sigma: float) -> np.ndarray:
    """`sigma` times the normal quantiles, rounded to whole levels. Shape (65536,), int16."""
    return np.rint(_normal_quantiles() * np.float32(sigma)).astype(np.int16)


class CameraRig:
    """The scenario's cameras on a compiled model.

    Args:
        model: The compiled model (holding the scenario's cameras).
        scenario: The scenario (its `cameras` and `perception` sections).
        seed: Episode seed (image noise stream).
    """

    def __init__(self, model: mujoco.MjModel, scenario: Scenario, seed: int) -> None:
        self.model = model
        self.scenario = scenario
        self.specs = {c.name: c for c in scenario.cameras}
        self.intrinsics = {
            c.name: Intrinsics.from_fovy(c.width, c.height, c.fovy_deg) for c in scenario.cameras
        }
        self._rng = stream(seed, "camera_noise")
        self._renderer: Renderer | None = None
        self.frames = 0
        """Frames captured so far."""
        self.segmentation = False
        """Render the segmentation image too (a second pass for OpenGL): for a recording."""

    def __getstate__(self) -> dict:
        # a snapshot (engine/snapshot) keeps the noise stream; the renderer (an OpenGL
        # context) opens again on first use
        return {**vars(self), "_renderer": None}

    @property
    def renderer(self) -> Renderer:
        """The renderer (opened on first use, as `perception.backend` asks)."""
        if self._renderer is None:
            self._renderer = open_renderer(self.model, self.scenario.perception.backend)
        return self._renderer

    def capture(self, data: mujoco.MjData, camera: str, segmentation: bool | None = None) -> Frame:
        """A frame of `camera` of the current state, with the scenario's pixel and depth noise.

        Args:
            data: The simulation state.
            camera: Camera name.
            segmentation: Render the geom-id image too (default: `self.segmentation`).

        Raises:
            PerceptionError: No camera of that name (the message lists the valid ones).
        """
        if camera not in self.specs:
            valid = ", ".join(self.specs) or "none: the scenario has no `cameras`"
            raise PerceptionError(f"no camera {camera!r} (valid: {valid})")
        cam_id = int(self.model.camera(camera).id)
        seg = self.segmentation if segmentation is None else segmentation
        frame = self.renderer.render(data, cam_id, self.intrinsics[camera], seg)
        self.frames += 1
        r = self.scenario.perception.randomize
        if r.pixel_noise <= 0.0 and r.depth_noise_m <= 0.0:
            return frame
        rgb, depth = frame.rgb, frame.depth
        if r.pixel_noise > 0.0:
            # the image is whole levels: rint(level + noise) = level + rint(noise), so the
            # noise is looked up already rounded, in int16 (half the cost of float32 rounding)
            noisy = _rounded_normal(r.pixel_noise).take(self._indices(rgb.size))
            noisy = noisy.reshape(rgb.shape)
            noisy += rgb
            np.clip(noisy, 0, 255, out=noisy)
            rgb = noisy.astype(np.uint8)
        if r.depth_noise_m > 0.0:
            noisy = _normal_quantiles().take(self._indices(depth.size)).reshape(depth.shape)
            noisy *= np.float32(r.depth_noise_m)
            noisy += depth
            noisy[depth <= 0.0] = 0.0  # nothing hit stays nothing hit
            depth = noisy
        return Frame(
            frame.camera,
            frame.backend,
            rgb,
            depth,
            frame.seg,
            frame.intrinsics,
            frame.pos,
            frame.rot,
        )

    def _indices(self, n: int) -> np.ndarray:
        """`n` random indices into the quantile tables (16 random bits each, 65536 levels):
        the bit generator's raw 64-bit words cut in four, 3x cheaper than `Generator.bytes`
        and 10x cheaper than `standard_normal`. Shape (n,), uint16."""
        words = self._rng.bit_generator.random_raw((n + 3) // 4)
        # little-endian whatever the machine: the same seed gives the same noise everywhere
        return np.asarray(words, "<u8").view("<u2")[:n]

    def close(self) -> None:
        """Free the renderer (an OpenGL context)."""
        close = getattr(self._renderer, "close", None)
        if close is not None:
            close()
        self._renderer = None
