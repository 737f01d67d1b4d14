"""The cameras of one episode: a renderer opened on first use, and the sensor's noise.

Rendering happens only when a skill asks for a frame (`detect`, at a control tick), never on
the physics step. Image noise is drawn from its own random stream (seed, frame count), so a
run is reproducible bit for bit.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import mujoco
import numpy as np

from .backends import Renderer, open_renderer
from .exceptions import PerceptionError
from .frame import Frame, Intrinsics

if TYPE_CHECKING:
    from ..language.scenario import Scenario

__all__ = ["CameraRig"]


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
        self._rng = np.random.default_rng([seed, 0x1A6E])
        self._renderer: Renderer | None = None
        self.frames = 0
        """Frames captured so far."""
        self.segmentation = False
        """Render the segmentation image too (a second pass for OpenGL): for a recording."""

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
            noise = self._rng.standard_normal(rgb.shape, dtype=np.float32)
            noise *= np.float32(r.pixel_noise)
            noise += rgb
            rgb = np.clip(np.rint(noise), 0, 255).astype(np.uint8)
        if r.depth_noise_m > 0.0:
            noisy = depth + np.float32(r.depth_noise_m) * self._rng.standard_normal(
                depth.shape, dtype=np.float32
            )
            depth = np.where(depth > 0.0, noisy, 0.0).astype(np.float32)
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

    def close(self) -> None:
        """Free the renderer (an OpenGL context)."""
        close = getattr(self._renderer, "close", None)
        if close is not None:
            close()
        self._renderer = None
