"""The 3D view framed on the work area, and detection labels that read on any object."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from orchestrator.engine.runner import run_episode
from orchestrator.language.load import load_scenario
from orchestrator.recording.blueprint import scene_aspect
from orchestrator.recording.camera_shots import contrasting
from orchestrator.recording.framing import FOV_Y_DEG, work_frame


class _Stop(Exception):
    pass


def _start(name: str):
    """The work frame and the fixed geoms' names and AABB corners of scenario `name` as its
    episode starts."""
    seen = {}

    class Probe:
        def on_start(self, ctx, executor):
            m, d = ctx.model, ctx.data
            seen["frame"] = work_frame(ctx)
            seen["geoms"] = {
                mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, g): d.geom_xpos[g].copy()
                for g in range(m.ngeom)
                if int(m.body_weldid[m.geom_bodyid[g]]) == 0
            }
            raise _Stop

    with pytest.raises(_Stop):
        run_episode(load_scenario(name), 0, [Probe()])
    return seen


def _project(frame, aspect: float, points: np.ndarray) -> np.ndarray:
    """Points in the 3D panel as fractions of its half width and half height (|v| <= 1:
    inside), seen from the eye the blueprint gives the view."""
    eye, target = frame.eye_for(aspect)
    forward = target - eye
    forward /= np.linalg.norm(forward)
    right = np.cross(forward, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    rel = points - eye
    depth = rel @ forward
    tan_v = math.tan(math.radians(FOV_Y_DEG) / 2)
    return np.stack([rel @ right / depth / (tan_v * aspect), rel @ up / depth / tan_v], axis=1)


@pytest.mark.parametrize(
    ("scenario", "work"),
    [("sorting", ["table_top", "bin_A", "bin_C"]), ("pick_place_vision", ["table_top", "pad"]),
     ("mobile_search", ["table_top", "side_table"])],
)  # fmt: skip
def test_the_work_area_fills_the_3d_view_and_stays_in_it(scenario, work):
    # sorting and pick_place_vision showed the table at ~30 % of the panel, mobile_search the
    # whole room small: the eye now sits as near as keeps the work area inside the panel
    seen = _start(scenario)
    frame = seen["frame"]
    for aspect in (scene_aspect(0.3, 0.4), scene_aspect(0.45, 0.6)):
        xy = _project(frame, aspect, frame.points)
        assert np.abs(xy).max() <= 1.0 + 1e-9  # every part of the work area is in view
        # and it fills the panel along its tighter side
        assert max(np.ptp(xy[:, 0]), np.ptp(xy[:, 1])) >= 1.6
        spots = _project(frame, aspect, np.array([seen["geoms"][g] for g in work]))
        assert np.abs(spots).max() < 1.0


@pytest.mark.parametrize(
    "rgb", [(217, 38, 38), (51, 178, 64), (38, 76, 217), (235, 220, 40), (128, 128, 128),
            (250, 250, 250), (10, 10, 10)],
)  # fmt: skip
def test_a_detection_label_contrasts_with_the_object_it_names(rgb):
    image = np.zeros((40, 60, 3), np.uint8)
    image[10:30, 20:40] = rgb
    color = contrasting(image, (20, 10, 20, 20))
    label = np.array([(color >> s) & 0xFF for s in (24, 16, 8)], float) / 255.0

    def lum(c):
        c = np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)
        return float(c @ [0.2126, 0.7152, 0.0722])

    a, b = lum(label), lum(np.array(rgb) / 255.0)
    assert (max(a, b) + 0.05) / (min(a, b) + 0.05) >= 4.5  # WCAG AA for text


def test_the_names_of_markers_in_a_row_are_written_apart():
    from orchestrator.recording.targets import label_raises

    xs = {"A": 0.31, "B": 0.48, "C": 0.65}
    bins = {f"bin_{c}": np.array([x, 0.25, 0.2]) for c, x in xs.items()}
    raises = label_raises({**bins, "pad": np.array([2.0, 0.0, 0.2])})
    assert raises["pad"] == 0.0  # alone: at the marker
    # seen from the eye, each bin's name sits at a height of its own, the nearest lowest
    heights = sorted(raises[b] for b in bins)
    assert len(set(heights)) == 3 and heights[0] == 0.0
    assert raises["bin_C"] < raises["bin_B"] < raises["bin_A"]
