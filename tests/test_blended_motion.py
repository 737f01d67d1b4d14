"""Blended motion: paths through via points, timed within the limits, that do not stop at
the via points and keep to their path when the joints limit them."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from orchestrator.skills.blended_path import BlendedPath
from orchestrator.skills.targets import rot_down

from orchestrator.engine.runner import run_episode
from orchestrator.language.load import load_scenario

DOWN = rot_down(0.0)
CORNER = np.array([[0.3, 0.0, 0.5], [0.5, -0.1, 0.33], [0.5, -0.1, 0.225]])


def _sampled(path: BlendedPath, dt: float = 0.001) -> tuple[np.ndarray, np.ndarray]:
    t = np.arange(0.0, path.duration + dt, dt)
    return t, np.array([path.sample(x)[0] for x in t])


def test_a_blended_path_runs_from_start_to_goal_within_its_limits():
    path = BlendedPath(CORNER, DOWN, DOWN, 0.8, 4.0, 2.0, 8.0, 0.04)
    t, xyz = _sampled(path, 0.005)
    assert np.allclose(xyz[0], CORNER[0])
    assert np.allclose(path.sample(path.duration)[0], CORNER[-1], atol=1e-9)
    speed = np.linalg.norm(np.diff(xyz, axis=0), axis=1) / np.diff(t)
    assert speed.max() <= 0.8 * 1.01
    acc = np.linalg.norm(np.diff(xyz, 2, axis=0), axis=1) / 0.005**2
    assert acc.max() <= 4.0 * np.sqrt(2.0) * 1.05  # along the path and centripetal, each <= 4


def test_a_blended_path_rounds_the_corner_without_stopping_and_stays_near_the_via_point():
    path = BlendedPath(CORNER, DOWN, DOWN, 0.8, 4.0, 2.0, 8.0, 0.04)
    t, xyz = _sampled(path)
    speed = np.linalg.norm(np.diff(xyz, axis=0), axis=1) / np.diff(t)
    inner = (t[1:] > 0.1 * path.duration) & (t[1:] < 0.9 * path.duration)
    assert speed[inner].min() > 0.15  # it never stops at the via point
    closest = np.min(np.linalg.norm(xyz - CORNER[1], axis=1))
    assert 0.001 < closest < 0.04  # it cuts the corner, but within the blend distance


def test_a_sharp_corner_is_passed_at_rest():
    path = BlendedPath(CORNER, DOWN, DOWN, 0.8, 4.0, 2.0, 8.0, 0.0)
    t, xyz = _sampled(path)
    closest = int(np.argmin(np.linalg.norm(xyz - CORNER[1], axis=1)))
    assert np.linalg.norm(xyz[closest] - CORNER[1]) < 1e-3
    speed = np.linalg.norm(xyz[closest + 1] - xyz[closest - 1]) / 0.002
    assert speed < 0.1


def test_the_orientation_is_reached_at_the_last_via_point():
    yawed = rot_down(0.6)
    path = BlendedPath(CORNER, DOWN, yawed, 0.8, 4.0, 2.0, 8.0, 0.04)
    t = np.linspace(0.0, path.duration, 400)
    s = np.array([path.progress(x) for x in t])
    after = t[s >= path.s_rot + 1e-6]
    assert len(after) > 10
    for x in after[::20]:
        assert np.allclose(path.sample(x)[1], yawed, atol=1e-9)


MACHINE = """\
name: via_move
initial: MOVE
blackboard: {hover: [0.5, -0.1, 0.35], goal: [0.5, -0.1, 0.25]}
states:
  MOVE:
    skill: move
    with: {target: $goal, via: [{target: $hover}], blend_m: 0.03, max_speed: 0.8, max_accel: 4.0}
    transitions: {reached: DONE, unreachable: FAILED, timeout: FAILED}
  DONE: {final: succeeded}
  FAILED: {final: failed}
"""


class Probe:
    def on_start(self, ctx, executor):
        self.rows = []

    def on_tick(self, ctx, executor):
        self.rows.append((ctx.t, ctx.tcp_pos.copy(), np.abs(ctx.qd).copy(), executor.done))

    def on_end(self, ctx, executor, result):
        pass


@pytest.fixture
def via_move(tmp_path: Path):
    (tmp_path / "via_move.yaml").write_text(MACHINE)
    (tmp_path / "scenario.yaml").write_text("name: via_move\nmachine: via_move.yaml\n")
    return load_scenario(str(tmp_path / "scenario.yaml"))


def test_a_move_through_a_via_point_does_not_stop_there_and_ends_at_its_goal(via_move):
    probe = Probe()
    result = run_episode(via_move, 0, [probe])
    assert result.outcome == "succeeded"
    t = np.array([r[0] for r in probe.rows])
    tcp = np.array([r[1] for r in probe.rows])
    speed = np.linalg.norm(np.diff(tcp, axis=0), axis=1) / np.diff(t)
    hover = np.array([0.5, -0.1, 0.35])
    near = int(np.argmin(np.linalg.norm(tcp - hover, axis=1)))
    assert np.linalg.norm(tcp[near] - hover) < 0.03
    assert speed[near - 2 : near + 2].min() > 0.1  # passing, not stopping
    assert np.linalg.norm(tcp[-1] - np.array([0.5, -0.1, 0.25])) < 0.002


def test_the_joints_stay_within_their_limits_on_a_fast_move_from_home(via_move):
    probe = Probe()
    run_episode(via_move, 0, [probe])
    qd = np.array([r[2] for r in probe.rows])
    panda_limits = np.array([2.175, 2.175, 2.175, 2.175, 2.61, 2.61, 2.61])
    assert np.all(qd[:, :7].max(axis=0) <= panda_limits)


def test_a_via_point_naming_an_unknown_scene_target_is_refused_before_the_run(tmp_path, cli):
    (tmp_path / "via_move.yaml").write_text(
        MACHINE.replace("[{target: $hover}]", "[{target: bucket}]")
    )
    (tmp_path / "scenario.yaml").write_text("name: via_move\nmachine: via_move.yaml\n")
    res = cli("validate", str(tmp_path / "scenario.yaml"))
    assert res.exit_code == 2
    assert "bucket" in res.stderr and "via" in res.stderr
