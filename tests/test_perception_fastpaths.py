"""Perception's fast paths give what the general functions they replace give.

`detect` is budgeted at 15 ms per 320x240 frame (bench/perception.py); to fit, the vision
pipeline uses shortcuts — labelling without OpenCV's statistics, quantiles from one partition,
a blob's row ends for its minimum-area rectangle, back-projection without a matmul, noise from
rounded tables. Each is held here to the slow reference it replaces.
"""

from __future__ import annotations

import dataclasses

import cv2
import mujoco
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from orchestrator.language.load import load_scenario
from orchestrator.perception import opengl
from orchestrator.perception.backends import backend_status
from orchestrator.perception.detections import quantile, row_ends
from orchestrator.perception.frame import Frame, Intrinsics
from orchestrator.perception.opengl import _upload_key
from orchestrator.perception.rig import CameraRig
from orchestrator.perception.vision import components
from orchestrator.world.world import World

masks = arrays(
    np.uint8, st.tuples(st.integers(1, 24), st.integers(1, 24)), elements=st.sampled_from([0, 255])
)


@settings(max_examples=150, deadline=None)
@given(masks)
def test_components_are_opencvs_components_with_their_pixels_in_row_major_order(mask):
    n, labels, stats, _ = cv2.connectedComponentsWithStats(mask, connectivity=8)
    want = [np.nonzero(labels == i) for i in range(1, n)]
    got = components(mask)
    assert len(got) == len(want)
    for (rows, cols), (wr, wc) in zip(got, want, strict=True):
        assert np.array_equal(rows, wr) and np.array_equal(cols, wc)


finite = st.floats(-1e3, 1e3, allow_nan=False, width=64)


@settings(max_examples=200, deadline=None)
@given(arrays(np.float64, st.integers(1, 300), elements=finite), st.sampled_from([0.5, 0.95]))
def test_quantile_is_numpys_linear_quantile(values, q):
    assert quantile(values, q) == pytest.approx(float(np.quantile(values, q)), abs=1e-9)


@pytest.mark.parametrize("seed", range(8))
def test_the_row_ends_of_a_blob_give_its_minimum_area_rectangle(seed):
    rng = np.random.default_rng(seed)
    h, w = 60, 80
    yy, xx = np.mgrid[:h, :w]
    a, b, t = rng.uniform(6, 25), rng.uniform(4, 18), rng.uniform(0, np.pi)
    cx, cy = rng.uniform(25, 55), rng.uniform(20, 40)
    u = (xx - cx) * np.cos(t) + (yy - cy) * np.sin(t)
    v = -(xx - cx) * np.sin(t) + (yy - cy) * np.cos(t)
    inside = (np.abs(u) <= a) & (np.abs(v) <= b)  # a rotated rectangle of pixels
    inside &= rng.random((h, w)) > 0.1  # with holes inside
    rows, cols = np.nonzero(inside)
    every = cv2.minAreaRect(np.column_stack([cols, rows]).astype(np.float32))
    ends = row_ends(rows)
    assert len(ends) < len(rows) / 3
    fast = cv2.minAreaRect(np.column_stack([cols[ends], rows[ends]]).astype(np.float32))
    assert sorted(fast[1]) == pytest.approx(sorted(every[1]), abs=1e-3)
    assert fast[0] == pytest.approx(every[0], abs=1e-3)


def test_backprojected_pixels_project_back_onto_their_centres():
    rng = np.random.default_rng(1)
    k = Intrinsics.from_fovy(64, 48, 50.0)
    rot = np.linalg.qr(rng.normal(size=(3, 3)))[0]
    rot *= np.linalg.det(rot)  # a rotation
    depth = rng.uniform(0.3, 1.5, (48, 64)).astype(np.float32)
    depth[5, 7] = 0.0  # nothing hit
    frame = Frame(
        "c", "raycast", np.zeros((48, 64, 3), np.uint8), depth, None, k, rng.normal(size=3), rot
    )
    rows, cols = np.nonzero(np.ones((48, 64), bool))
    pts = frame.backproject(rows, cols)
    hit = depth[rows, cols] > 0
    assert np.all(np.isnan(pts[~hit]))
    uv = frame.project(pts[hit])
    assert uv[:, 0] == pytest.approx(cols[hit] + 0.5, abs=1e-6)
    assert uv[:, 1] == pytest.approx(rows[hit] + 0.5, abs=1e-6)
    local = (pts[hit] - frame.pos) @ rot
    assert -local[:, 2] == pytest.approx(depth[rows, cols][hit], abs=1e-6)


@pytest.fixture(scope="module")
def vision_world():
    loaded = load_scenario("pick_place_vision")
    scn = loaded.scenario.model_copy(
        update={"perception": loaded.scenario.perception.model_copy(update={"backend": "raycast"})}
    )
    world = World.build(scn, 5)
    mujoco.mj_forward(world.model, world.data)
    return scn, world


def test_the_offscreen_buffer_is_the_cameras_size_with_one_sample_per_pixel(vision_world):
    # MuJoCo's default buffer (640x480, 4x multisampling) made one 320x240 frame cost 3x more
    # on a software OpenGL and blended every cube's edge into the table's colour
    scn, world = vision_world
    glob, quality = world.model.vis.global_, world.model.vis.quality
    assert (glob.offwidth, glob.offheight) == (
        max(c.width for c in scn.cameras),
        max(c.height for c in scn.cameras),
    )
    assert quality.offsamples == 0


class _SkyAbove:
    """A renderer whose frames see nothing (depth 0) in their top ten rows."""

    name = "raycast"

    def __init__(self, inner) -> None:
        self.inner = inner

    def render(self, data, cam_id, intrinsics, segmentation):
        frame = self.inner.render(data, cam_id, intrinsics, segmentation)
        depth = frame.depth.copy()
        depth[:10] = 0.0
        return dataclasses.replace(frame, depth=depth)


def test_depth_noise_has_its_standard_deviation_and_leaves_no_hit_at_zero(vision_world):
    scn, world = vision_world
    cam = int(world.model.camera("overhead").id)

    def rig():
        r = CameraRig(world.model, scn, 5)
        r._renderer = _SkyAbove(r.renderer)
        return r

    first = rig()
    clean = first.renderer.render(world.data, cam, first.intrinsics["overhead"], False).depth
    noisy = first.capture(world.data, "overhead").depth
    sigma = scn.perception.randomize.depth_noise_m
    assert sigma > 0 and noisy.dtype == np.float32
    hit = clean > 0
    diff = (noisy - clean)[hit].astype(float)
    assert abs(diff.mean()) < 0.05 * sigma and diff.std() == pytest.approx(sigma, rel=0.05)
    assert np.all(noisy[:10] == 0.0)  # nothing hit stays nothing hit
    assert np.array_equal(rig().capture(world.data, "overhead").depth, noisy)  # same seed
    assert not np.array_equal(first.capture(world.data, "overhead").depth, noisy)  # per frame


def test_hue_margins_are_the_same_for_boxes_given_as_lists_or_tuples():
    from orchestrator.perception.colours import hsv_boxes
    from orchestrator.perception.vision import hue_margin

    red = hsv_boxes("red")
    as_lists = [[list(lo), list(hi)] for lo, hi in red]  # as a Python caller may write them
    for hue in (0.0, 2.0, 7.5, 175.0):
        assert hue_margin(hue, as_lists) == hue_margin(hue, red)
    assert hue_margin(2.0, red) == 7.0  # red ends at 8: 9, the first hue outside it, is 7 away


@pytest.mark.skipif(not backend_status().opengl, reason="no OpenGL context on this machine")
def test_parcels_of_new_sizes_keep_the_gl_context_and_render_what_a_fresh_one_renders():
    # the sorting scene draws new parcel sizes every episode: rebuilding the MjrContext for each
    # (~110 ms) bought nothing, since boxes are unit shapes scaled when drawn
    scn = load_scenario("sorting").scenario
    worlds = [World.build(scn, seed) for seed in (0, 1)]
    assert not np.array_equal(worlds[0].model.geom_size, worlds[1].model.geom_size)
    assert _upload_key(worlds[0].model) == _upload_key(worlds[1].model)

    def frame(world: World, fresh: bool) -> Frame:
        if fresh:
            opengl._shared.clear()
        mujoco.mj_forward(world.model, world.data)
        rig = CameraRig(world.model, scn, 0)
        return rig.renderer.render(world.data, 0, rig.intrinsics["overhead"], True)

    frame(worlds[0], fresh=True)  # the context made for seed 0's parcels
    kept, fresh = frame(worlds[1], fresh=False), frame(worlds[1], fresh=True)
    assert kept.backend == fresh.backend == "opengl"
    assert np.array_equal(kept.rgb, fresh.rgb)
    assert np.array_equal(kept.depth, fresh.depth)
    assert np.array_equal(kept.seg, fresh.seg)
    # a plane's size is uploaded (its grid): a different floor still gets its own context
    other = World.build(scn, 0).model
    other.geom_size[other.geom_type == mujoco.mjtGeom.mjGEOM_PLANE] *= 2.0
    assert _upload_key(other) != _upload_key(worlds[0].model)
