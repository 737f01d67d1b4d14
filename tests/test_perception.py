"""Perception: cameras, the two renderers, colour detection and the `detect` skill."""

from __future__ import annotations

import ctypes.util
import json
import os
import subprocess
import sys

import mujoco
import numpy as np
import pytest

from orchestrator.engine.runner import run_episode
from orchestrator.language.load import load_scenario
from orchestrator.perception.backends import backend_status
from orchestrator.perception.detections import detect_objects
from orchestrator.perception.rig import CameraRig
from orchestrator.perception.truth import fully_in_view, match_detections, true_objects
from orchestrator.world.world import World

from .conftest import REPO

CAMERA = "overhead"


@pytest.fixture(scope="module")
def vision():
    return load_scenario("pick_place_vision")


def _world(loaded, seed: int, backend: str):
    scn = loaded.scenario.model_copy(
        update={"perception": loaded.scenario.perception.model_copy(update={"backend": backend})}
    )
    world = World.build(scn, seed)
    mujoco.mj_forward(world.model, world.data)
    return world, CameraRig(world.model, scn, seed)


def _detect(world, rig):
    frame = rig.capture(world.data, CAMERA)
    boxes = world.scenario.perception.class_boxes()
    noise = world.scenario.perception.randomize.depth_noise_m
    return frame, detect_objects(frame, boxes, 30, None, noise)


@pytest.mark.parametrize("seed", [0, 7])
def test_detections_match_the_truth_in_class_position_and_yaw(vision, seed):
    world, rig = _world(vision, seed, "raycast")
    frame, found = _detect(world, rig)
    truths = true_objects(world)
    assert all(fully_in_view(t, frame) for t in truths)
    matches = match_detections(found, truths)
    assert sorted(m.truth.name for m in matches if m.truth) == sorted(t.name for t in truths)
    for m in matches:
        assert m.correct, (m.detection.cls, m.truth)
        assert m.detection.confidence >= 0.5
        assert m.position_error_m < 0.003
        assert m.yaw_error_deg < 3.0


@pytest.mark.skipif(not backend_status().opengl, reason="no OpenGL context on this machine")
@pytest.mark.parametrize("seed", [1, 4])
def test_opengl_and_raycast_agree_on_classes_and_positions_within_2mm(vision, seed):
    results = {}
    for backend in ("opengl", "raycast"):
        world, rig = _world(vision, seed, backend)
        frame, found = _detect(world, rig)
        assert frame.backend == backend
        results[backend] = found
        rig.close()
    gl, rc = results["opengl"], results["raycast"]
    assert [d.cls for d in gl] == [d.cls for d in rc]
    for a, b in zip(gl, rc, strict=True):
        assert np.linalg.norm(a.pos - b.pos) < 0.002


def test_a_blob_cut_by_the_region_of_interest_keeps_its_class_with_low_confidence(vision):
    world, rig = _world(vision, 0, "raycast")
    frame = rig.capture(world.data, CAMERA)
    boxes = world.scenario.perception.class_boxes()
    whole = [d for d in detect_objects(frame, boxes) if d.cls == "red"]
    x, y, w, h = whole[0].bbox
    roi = (0, 0, x + w // 2, frame.intrinsics.height)  # the right half of the red cube cut off
    near = lambda d: np.linalg.norm(d.pos[:2] - whole[0].pos[:2]) < 0.03  # noqa: E731
    cut = [d for d in detect_objects(frame, boxes, roi=roi) if near(d)]
    assert [d.cls for d in cut] == ["red"]
    assert whole[0].confidence >= 0.9
    assert cut[0].confidence < 0.5


def test_pixel_noise_is_drawn_per_seed_and_reproducible(vision):
    a = _detect(*_world(vision, 3, "raycast"))[0].rgb
    b = _detect(*_world(vision, 3, "raycast"))[0].rgb
    c = _detect(*_world(vision, 4, "raycast"))[0].rgb
    assert np.array_equal(a, b)
    assert not np.array_equal(a, c)
    world, rig = _world(vision, 3, "raycast")
    clean = rig.renderer.render(world.data, 0, rig.intrinsics[CAMERA], False).rgb.astype(float)
    inside = (clean > 20) & (clean < 235)  # no clipping at 0 or 255
    diff = (a.astype(float) - clean)[inside]
    sigma = vision.scenario.perception.randomize.pixel_noise
    assert abs(diff.mean()) < 0.05 and diff.std() == pytest.approx(sigma, rel=0.05)


def test_pick_place_vision_picks_the_red_cube_by_camera(vision):
    result = run_episode(vision, 2)
    assert result.outcome == "succeeded", result.metrics
    m = result.metrics
    assert m["misclassified"] == 0
    assert 0.0 < m["detection_error_mm"] < 3.0
    assert m["detection_yaw_error_deg"] < 3.0
    assert m["perception_backend"] in ("opengl", "raycast")
    again = run_episode(vision, 2)
    assert again.metrics == result.metrics and again.transitions == result.transitions


def test_detect_writes_the_documented_detection_records(vision):
    from orchestrator.engine.context import Context  # noqa: F401 - the blackboard contract

    captured = {}

    class Grab:
        def on_start(self, ctx, executor):
            self.ctx = ctx

        def on_tick(self, ctx, executor):
            if "detections" in ctx.blackboard and ctx.blackboard["detections"] and not captured:
                captured["d"] = ctx.blackboard["detections"]
                captured["pose"] = ctx.blackboard["object_pose"]

        def on_end(self, ctx, executor, result):
            pass

    run_episode(vision, 0, [Grab()])
    dets = captured["d"]
    assert [d["id"] for d in dets] == list(range(len(dets)))
    assert {"id", "class", "pose", "confidence", "pixels", "bbox", "size_m", "camera"} <= set(
        dets[0]
    )
    assert [d["class"] for d in dets] == ["red"]  # the machine asks for class red only
    assert captured["pose"].pos == pytest.approx(dets[0]["pose"]["pos"])
    json.dumps(dets)  # plain data


def test_an_unknown_colour_class_or_camera_is_a_located_error(cli):
    res = cli("run", "pick_place_vision", "--seed", "0", "--set", "blackboard.target_class=pink")
    assert res.exit_code == 2
    assert "no colour class 'pink'" in res.stdout + res.stderr
    assert "valid: red, green, blue, yellow" in res.stdout + res.stderr
    res = cli("run", "pick_place_vision", "--seed", "0", "--set", "blackboard.camera=wrist")
    assert res.exit_code == 2
    assert "pick_place_vision.yaml:" in res.stdout + res.stderr
    assert "no camera 'wrist'" in res.stdout + res.stderr


_NO_EGL = """
import sys
sys.modules["OpenGL.EGL"] = None  # as on a machine without libEGL: importing it fails
from orchestrator.perception.backends import backend_status
from orchestrator.engine.runner import run_episode
from orchestrator.language.load import load_scenario
status = backend_status()
result = run_episode(load_scenario("pick_place_vision"), 5)
print(status.opengl, status.platform, result.outcome, result.metrics["perception_backend"])
"""


def test_without_libegl_and_mujoco_gl_unset_the_raycast_backend_takes_over():
    env = {k: v for k, v in os.environ.items() if k not in ("MUJOCO_GL", "DISPLAY")}
    env.pop("WAYLAND_DISPLAY", None)
    out = subprocess.run(
        [sys.executable, "-c", _NO_EGL],
        check=False,
        env=env,
        cwd=REPO,
        capture_output=True,
        text=True,
    )
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ["False", "egl", "succeeded", "raycast"]


@pytest.mark.skipif(
    ctypes.util.find_library("OSMesa") is not None, reason="OSMesa is installed here"
)
def test_mujoco_gl_naming_a_missing_library_falls_back_to_raycast_instead_of_crashing():
    env = dict(os.environ, MUJOCO_GL="osmesa")
    code = (
        "import orchestrator, mujoco\n"
        "from orchestrator.perception.backends import backend_status\n"
        "print(backend_status().describe())"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], check=False, env=env, cwd=REPO, capture_output=True, text=True
    )
    assert out.returncode == 0, out.stderr
    assert (
        out.stdout.strip()
        == "raycast (no OpenGL via none: MUJOCO_GL=osmesa but libOSMesa is missing)"
    )


def test_the_recording_shows_the_camera_images_and_boxes_at_each_detect(vision, tmp_path):
    from .test_recording import record

    rec = record(vision, 0, tmp_path / "vision.rrd")
    cam = "/world/cameras/overhead"
    detect_t = [t["t"] for t in rec.result.transitions if t["from"] == "PICK.DETECT"]
    for entity in (f"{cam}/rgb", f"{cam}/depth", f"{cam}/segmentation", f"{cam}/detections"):
        rows = rec.temporal[entity]
        assert len(rows) == len(detect_t), entity  # once per detect call, not per tick
        assert [r["sim_time"].total_seconds() for r in rows] == pytest.approx(detect_t)
    labels = rec.column(f"{cam}/detections", "Boxes2D:labels")
    assert labels[0][0].startswith("red ")
    assert rec.column(cam, "Pinhole:resolution")[0][0] == pytest.approx([320, 240])


def test_a_bad_region_of_interest_is_a_located_error(cli, write_yaml):
    path = write_yaml(
        "bad_roi.yaml",
        (REPO / "machines" / "pick_place_vision.yaml")
        .read_text()
        .replace("pose_into: object_pose}", "pose_into: object_pose, roi: [100, 0, 50, 240]}"),
    )
    scenario = write_yaml(
        "s.yaml",
        (REPO / "scenarios" / "pick_place_vision.yaml")
        .read_text()
        .replace("machine: pick_place_vision", f"machine: {path}"),
    )
    res = cli("validate", str(scenario))
    assert res.exit_code == 2
    text = res.stdout + res.stderr
    assert "bad_roi.yaml:" in text and "roi [100, 0, 50, 240]: need 0 <= x0 < x1" in text


def test_a_camera_mounted_on_the_hand_moves_with_it(vision):
    from orchestrator.language.scenario import CameraSpec

    wrist = CameraSpec(name="wrist", body="hand", pos=[0.0, 0.0, 0.1], quat=[0.0, 1.0, 0.0, 0.0])
    scn = vision.scenario.model_copy(update={"cameras": [*vision.scenario.cameras, wrist]})
    world = World.build(scn, 0)
    model, data = world.model, world.data
    hand = model.body(world.robot.hand_body).id
    cam = model.camera("wrist").id
    seen = []
    for q1 in (0.0, 0.4):
        data.qpos[1] = q1
        mujoco.mj_forward(model, data)
        rot = data.xmat[hand].reshape(3, 3)
        assert data.cam_xpos[cam] == pytest.approx(data.xpos[hand] + rot @ [0.0, 0.0, 0.1])
        frame = CameraRig(model, scn, 0).capture(data, "wrist")
        assert frame.pos == pytest.approx(data.cam_xpos[cam])
        seen.append(frame.pos.copy())
    assert np.linalg.norm(seen[0] - seen[1]) > 0.05


def test_two_touching_cubes_of_one_colour_are_two_detections(vision):
    from orchestrator.perception.vision import find_blobs

    red = [0.85, 0.15, 0.15, 1.0]
    cubes = [
        {"name": "a", "size": [0.05] * 3, "xy": [0.600, 0.100], "yaw_deg": 45.0, "rgba": red},
        {"name": "b", "size": [0.05] * 3, "xy": [0.584, 0.024], "yaw_deg": 40.0, "rgba": red},
    ]
    raw = vision.scenario.model_dump()
    raw["scene"]["objects"] = cubes
    raw["perception"]["backend"] = "raycast"
    scn = type(vision.scenario).model_validate(raw)
    world = World.build(scn, 0)
    mujoco.mj_forward(world.model, world.data)
    frame = CameraRig(world.model, scn, 0).capture(world.data, CAMERA)
    boxes = scn.perception.class_boxes()
    assert len(find_blobs(frame.rgb, boxes)) == 1  # their sides bridge the gap in the image
    matches = match_detections(detect_objects(frame, boxes), true_objects(world))
    assert sorted(m.truth.name for m in matches) == ["a", "b"]
    for m in matches:
        assert m.correct and m.detection.confidence >= 0.5
        assert m.position_error_m < 0.003


def test_a_red_whose_pixels_straddle_hue_zero_is_not_ambiguous():
    import cv2

    from orchestrator.perception.colours import hsv_boxes
    from orchestrator.perception.vision import find_blobs

    hsv = np.zeros((60, 60, 3), np.uint8)
    hsv[..., 1:] = (0, 128)  # grey background
    hsv[10:50, 10:50] = (2, 200, 200)
    hsv[10:50:2, 10:50] = (178, 200, 200)  # every other row just below 180: still red
    rgb = cv2.cvtColor(hsv, cv2.COLOR_HSV2RGB)
    blobs = find_blobs(rgb, {"red": hsv_boxes("red")})
    assert [b.cls for b in blobs] == ["red"]
    assert blobs[0].hue_margin >= 6.0  # mean hue 0: 9 steps to orange, 11 to magenta
