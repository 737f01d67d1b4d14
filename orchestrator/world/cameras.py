"""Cameras in the world and the per-seed appearance of what they see.

Cameras are MuJoCo cameras compiled into the model (fixed in the world, or on a robot body so
they move with it); MuJoCo keeps their world poses in `MjData.cam_xpos` / `cam_xmat`. What a
camera sees varies per seed on its own random stream: the light's intensity and direction and
the objects' colours (image noise is drawn per frame, by the perception layer).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import mujoco
import numpy as np

from .random_streams import stream

if TYPE_CHECKING:
    from ..language.scenario import CameraSpec, Scenario
    from ..robots import Robot

__all__ = ["HAND_ALIAS", "add_cameras", "camera_body", "look_at_quat", "randomize_appearance"]

HAND_ALIAS = "hand"
"""`body: hand` mounts a camera on the robot's hand, whatever the robot calls that body."""
_LIGHT = "sun"


def camera_body(spec: CameraSpec, robot: Robot) -> str | None:
    """The model body a camera is mounted on (None: fixed in the world)."""
    if spec.body is None:
        return None
    return robot.hand_body if spec.body == HAND_ALIAS else spec.body


def look_at_quat(pos: np.ndarray, target: np.ndarray, up: np.ndarray) -> np.ndarray:
    """Quaternion (w, x, y, z) of a MuJoCo camera at `pos` looking at `target`: its -z axis
    points at the target and its +y (the image's top) towards `up` (+x if `up` is parallel to
    the view). Shapes (3,)."""
    forward = np.asarray(target, float) - np.asarray(pos, float)
    forward /= np.linalg.norm(forward)
    right = np.cross(forward, up)
    if np.linalg.norm(right) < 1e-6:
        right = np.cross(forward, [1.0, 0.0, 0.0])
        if np.linalg.norm(right) < 1e-6:
            right = np.cross(forward, [0.0, 1.0, 0.0])
    right /= np.linalg.norm(right)
    top = np.cross(right, forward)
    rot = np.column_stack([right, top, -forward])
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, rot.ravel())
    return quat


def add_cameras(spec: mujoco.MjSpec, scenario: Scenario, robot: Robot) -> None:
    """Add the scenario's cameras to the model being built; size the offscreen buffer."""
    if not scenario.cameras:
        return
    for cam in scenario.cameras:
        name = camera_body(cam, robot)
        parent = spec.worldbody if name is None else spec.body(name)
        if parent is None:
            raise ValueError(f"camera {cam.name!r}: no body {cam.body!r} in the robot")
        if cam.look_at is not None:
            quat = look_at_quat(np.array(cam.pos), np.array(cam.look_at), np.array(cam.up))
        elif cam.quat is not None:
            quat = np.asarray(cam.quat, float) / np.linalg.norm(cam.quat)
        else:
            quat = np.array([1.0, 0.0, 0.0, 0.0])
        parent.add_camera(name=cam.name, pos=list(cam.pos), quat=quat.tolist(), fovy=cam.fovy_deg)
    _vision_lighting(spec)
    # The offscreen buffer is the cameras' alone: the size of the largest, one sample per
    # pixel. MuJoCo's default (640x480, 4x multisampling) made a 320x240 frame cost 10.7 ms
    # of CPU on a software OpenGL (llvmpipe) against 3.2 ms, and anti-aliased edges blend a
    # cube's colour into the table's: no help to colour segmentation.
    glob = spec.visual.global_
    glob.offwidth = max(c.width for c in scenario.cameras)
    glob.offheight = max(c.height for c in scenario.cameras)
    spec.visual.quality.offsamples = 0


def _vision_lighting(spec: mujoco.MjSpec) -> None:
    """Light a scene with cameras for colour vision: the sun becomes a directional light (the
    same brightness everywhere on the table, as the ray-cast camera assumes) and nothing is
    specular (a highlight washes a face out to white, and only OpenGL would draw it)."""
    sun = spec.light(_LIGHT)
    sun.type = mujoco.mjtLightType.mjLIGHT_DIRECTIONAL
    sun.specular = [0.0, 0.0, 0.0]
    head = spec.visual.headlight
    head.ambient = [0.2, 0.2, 0.2]
    head.diffuse = [0.15, 0.15, 0.15]
    head.specular = [0.0, 0.0, 0.0]


def randomize_appearance(
    model: mujoco.MjModel, scenario: Scenario, seed: int, object_geoms: list[int]
) -> None:
    """Per-seed light intensity and direction, and colour jitter of the objects' geoms.

    Does nothing without cameras, so scenarios without them keep their exact appearance.
    """
    if not scenario.cameras:
        return
    r = scenario.perception.randomize
    rng = stream(seed, "camera_light")
    scale = rng.uniform(r.light_intensity[0], r.light_intensity[1])
    tilt = math.radians(rng.uniform(0.0, r.light_tilt_deg))
    azimuth = rng.uniform(-math.pi, math.pi)
    light = model.light(_LIGHT).id
    model.light_diffuse[light] *= scale
    model.light_dir[light] = [
        math.sin(tilt) * math.cos(azimuth),
        math.sin(tilt) * math.sin(azimuth),
        -math.cos(tilt),
    ]
    for g in object_geoms:
        jitter = rng.normal(0.0, r.colour_jitter, 3)
        model.geom_rgba[g, :3] = np.clip(model.geom_rgba[g, :3] + jitter, 0.0, 1.0)
