"""Choosing the renderer: OpenGL when a context can be made, else the ray-cast camera.

`MUJOCO_GL` is respected: set, MuJoCo's own choice of context is used (`egl`, `osmesa`,
`glfw`; `disable` means none). Unset, a headless Linux (no `DISPLAY` / `WAYLAND_DISPLAY`) tries
EGL, anything else MuJoCo's default (GLFW). Only one OpenGL platform is ever tried in a
process — MuJoCo cannot switch platforms after one failed — and the verdict is kept for the
process, so a batch worker probes once.
"""

from __future__ import annotations

import functools
import os
import sys
import warnings
from dataclasses import dataclass
from typing import Literal, Protocol

import mujoco

from .exceptions import PerceptionError
from .frame import Frame, Intrinsics
from .raycast import RaycastCamera

__all__ = ["BackendStatus", "Renderer", "backend_status", "open_renderer"]

Preference = Literal["auto", "opengl", "raycast"]


class Renderer(Protocol):
    """What both camera backends offer."""

    name: str

    def render(
        self, data: mujoco.MjData, cam_id: int, intrinsics: Intrinsics, segmentation: bool
    ) -> Frame: ...


@dataclass(frozen=True)
class BackendStatus:
    """Whether OpenGL rendering works in this process, and why (not)."""

    opengl: bool
    platform: str
    """OpenGL platform tried: `egl`, `osmesa`, `glfw` or `none`."""
    detail: str
    """The error that ruled OpenGL out, or empty."""

    @property
    def chosen(self) -> str:
        """The backend `auto` uses: `opengl` or `raycast`."""
        return "opengl" if self.opengl else "raycast"

    def describe(self) -> str:
        """One line for people: which backend and why."""
        if self.opengl:
            return f"opengl ({self.platform})"
        why = f": {self.detail}" if self.detail else ""
        return f"raycast (no OpenGL via {self.platform}{why})"


_PROBE_XML = "<mujoco><worldbody><geom size='0.1'/></worldbody></mujoco>"


def _platform() -> str:
    env = os.environ.get("MUJOCO_GL", "").strip().lower()
    if env in ("disable", "disabled", "off", "false", "0"):
        return "none"
    if env:
        return env
    headless = not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))
    return "egl" if sys.platform.startswith("linux") and headless else "glfw"


def _context_class(platform: str) -> type:
    if platform == "egl" and not os.environ.get("MUJOCO_GL"):
        from mujoco.egl import GLContext  # MuJoCo's default would be GLFW: ask for EGL

        return GLContext
    return mujoco.GLContext  # MuJoCo's choice for MUJOCO_GL (AttributeError when disabled)


def _probe() -> BackendStatus:
    platform = _platform()
    if platform == "none":
        why = os.environ.get("ORCHESTRATOR_GL_MISSING") or "MUJOCO_GL disables OpenGL"
        return BackendStatus(False, "none", why)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # GLFW warns before it fails on a headless machine
            cls = _context_class(platform)
            ctx = cls(16, 16)
            ctx.make_current()
            con = mujoco.MjrContext(mujoco.MjModel.from_xml_string(_PROBE_XML), 50)
            con.free()
            ctx.free()
    except Exception as exc:  # any failure to get a GL context means: no OpenGL here
        return BackendStatus(False, platform, " ".join(str(exc).split())[:160])
    return BackendStatus(True, platform, "")


@functools.cache
def backend_status() -> BackendStatus:
    """Whether OpenGL works here (probed once per process)."""
    return _probe()


def open_renderer(model: mujoco.MjModel, preference: Preference = "auto") -> Renderer:
    """A renderer for `model`: OpenGL if preferred or available, else the ray-cast camera.

    Raises:
        PerceptionError: `opengl` was asked for and no OpenGL context can be made.
    """
    if preference == "raycast":
        return RaycastCamera(model)
    status = backend_status()
    if not status.opengl:
        if preference == "opengl":
            raise PerceptionError(
                f"perception.backend is `opengl` but no OpenGL context can be made "
                f"({status.describe()}); set MUJOCO_GL=egl or osmesa, or use `auto`/`raycast`"
            )
        return RaycastCamera(model)
    from .opengl import OpenGLCamera

    return OpenGLCamera(model, _context_class(status.platform))
