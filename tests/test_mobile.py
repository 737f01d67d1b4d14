"""Mobile manipulation: whole-body IK costs, the room map, base skills, the mobile_search flow."""

from __future__ import annotations

import math

import numpy as np
import pytest
from orchestrator.robots import get_robot
from orchestrator.skills.base_map import PLAN_RADIUS_M, base_map
from orchestrator.skills.ik import IKSolver
from orchestrator.skills.targets import rot_down

from orchestrator.engine.runner import run_episode
from orchestrator.language.load import load_scenario
from orchestrator.world.randomization import object_poses
from orchestrator.world.world import robot_only_model


def _solve(target, ticks=1500):
    robot = get_robot("mobile_panda")
    ik = IKSolver(robot, robot_only_model(robot), 0.01, np.zeros(3))
    ik.reset(np.array(robot.home))
    for _ in range(ticks):
        ik.reference_step(np.asarray(target, float), rot_down(0.0), 0.01)
        if np.linalg.norm(ik.error[:3]) < 5e-4:
            break
    return robot, ik


def test_whole_body_ik_the_arm_does_the_fine_motion():
    # 13 cm from the home TCP (0.43, 0, 0.71): the arm moves, the base hardly
    _, ik = _solve([0.55, 0.1, 0.7])
    assert np.linalg.norm(ik.error[:3]) < 1e-3
    assert np.linalg.norm(ik.q[:2]) < 0.01


def test_whole_body_ik_the_base_does_the_long_motion():
    # 1.8 m away: far beyond the arm's reach; the base carries the TCP there
    robot, ik = _solve([2.0, 1.0, 0.5])
    assert np.linalg.norm(ik.q[:2]) > 1.0
    shoulder = robot.shoulder(ik.q, np.zeros(3))
    tcp, _ = ik.tcp_pose()
    assert np.linalg.norm(tcp - shoulder) <= robot.reach_m


@pytest.fixture(scope="module")
def loaded():
    return load_scenario("mobile_search")


def test_planned_paths_keep_the_planning_radius_from_every_box(loaded):
    room = base_map(loaded.scenario)
    start = np.array([-1.6, -0.9])
    goal = np.array([0.1, -1.6])  # the straight line passes 0.4 m from the sofa's corner
    assert not room.segment_free(start, goal)
    corners = room.plan(start, goal)
    assert corners is not None and np.allclose(corners[-1], goal)
    pts = [start, *corners]
    for a, b in zip(pts[:-1], pts[1:], strict=True):
        for k in np.linspace(0.0, 1.0, 50):
            assert room.clearance(*(a + k * (b - a))) > PLAN_RADIUS_M
    assert room.plan(np.zeros(2), np.array([-2.2, 1.5])) is None  # inside the cabinet


def test_footprint_check_answers_as_its_outline_does(loaded):
    """`footprint_clear` answers a pose far from every box from its centre alone: over
    random poses, many of them grazing a box, it agrees with testing each outline point."""
    room = base_map(loaded.scenario)
    rng = np.random.default_rng(11)
    rect = (0.30, 0.25)

    def outline_clear(x, y, yaw, margin):
        hl, hw = rect[0] + margin, rect[1] + margin
        c, s = math.cos(yaw), math.sin(yaw)
        return all(
            room.clearance(x + c * u - s * v, y + s * u + c * v) > 0.0
            for u in np.linspace(-hl, hl, 9)
            for v in np.linspace(-hw, hw, 7)
            if not (abs(u) < hl - 1e-9 and abs(v) < hw - 1e-9)
        )

    answers, grazing = [], 0
    for _ in range(3000):
        x, y = rng.uniform(-2.6, 2.6, 2)
        yaw, margin = rng.uniform(-math.pi, math.pi), rng.uniform(0.0, 0.1)
        want = outline_clear(x, y, yaw, margin)
        assert room.footprint_clear(x, y, yaw, margin, rect) == want, (x, y, yaw, margin)
        answers.append(want)
        diag = math.hypot(rect[0] + margin, rect[1] + margin)
        grazing += abs(room.clearance(x, y) - diag) < 0.05  # where the shortcut's bound is
    assert 100 < sum(answers) < len(answers) - 100  # both answers occur
    assert grazing > 100


def test_the_red_block_starts_on_a_table_or_the_floor_clear_of_the_others(loaded):
    scn = loaded.scenario
    heights = set()
    for seed in range(200):
        poses = {n: p for n, p, _ in object_poses(scn, seed)}
        cube = poses.pop("cube")
        heights.add(round(float(cube[2]) - 0.025, 3))
        for other in poses.values():
            assert np.linalg.norm(cube[:2] - other[:2]) > 0.15
    assert heights == {0.0, 0.45, 0.6}  # the floor, the side table, the desk


class _FinalQ:
    """Keeps the joint angles at the end of a run."""

    q: np.ndarray

    def on_start(self, ctx, executor) -> None:
        pass

    def on_tick(self, ctx, executor) -> None:
        pass

    def on_end(self, ctx, executor, result) -> None:
        self.q = ctx.q.copy()


def test_drive_and_turn_reach_their_poses_within_the_bases_limits(tmp_path):
    machine = tmp_path / "m.yaml"
    machine.write_text(
        "name: m\ninitial: A\nstates:\n"
        "  A:\n    skill: drive\n    with: {to: [-1.2, 1.1, 90.0]}\n"
        "    transitions: {reached: B, blocked: F, timeout: F}\n"
        "  B:\n    skill: turn\n    with: {by_deg: -135.0}\n"
        "    transitions: {turned: D, timeout: F}\n"
        "  D: {final: succeeded}\n  F: {final: failed}\n"
    )
    loaded = load_scenario("mobile_search", machine=str(machine), allow_paths=[tmp_path])
    final = _FinalQ()
    result = run_episode(loaded, 0, [final])
    # joint_velocity (0.5 m/s, 1 rad/s), joint_limits and collision guards watch all along
    assert result.outcome == "succeeded", result.reason
    q = final.q
    assert q[0] == pytest.approx(-1.2, abs=0.01) and q[1] == pytest.approx(1.1, abs=0.01)
    assert math.degrees(q[2]) == pytest.approx(-45.0, abs=1.0)
    straight = math.hypot(1.2, 1.1)  # the path is straight: nothing in the way
    assert straight - 0.03 <= result.metrics["base_travel_m"] <= straight + 0.05


@pytest.mark.slow  # a whole mobile search with a recovery (~7 s CPU); the search itself runs
# in the default suite below (seed 18), the recovery path in bench/off_nominal.py too
def test_target_moved_during_the_approach_is_looked_for_again_and_grasped():
    # pushed away while the base closes in: the grasp misses, the arm is stowed and the base
    # backs out to the viewing distance (APPROACHING again), looks, closes in and grasps
    push = "push:object=cube,force_n=[0,2,0],duration_ms=200@APPROACHING.CLOSE_IN+0.5"
    result = run_episode(load_scenario("mobile_search", faults=[push]), 0)
    visits = [t["to"] for t in result.transitions]
    first_grasp = next(i for i, s in enumerate(visits) if s.startswith("GRASPING"))
    after = visits[first_grasp:]
    assert "RECOVER" in after and "APPROACHING.VIEW" in after[after.index("RECOVER") :], visits
    assert result.outcome == "succeeded", (result.reason, result.success_detail)
    assert result.success["cube_lifted"]


def test_a_block_seen_20_deg_off_from_afar_is_still_grasped():
    # Seed 18: the look from the viewing distance reads the block's yaw 20 deg off; with the
    # grasp machine's 30 mm pre-shape a finger landed on the block's top (110 N, aborted).
    result = run_episode(load_scenario("mobile_search"), 18)
    assert result.metrics["detection_yaw_error_deg"] > 15.0  # the case this test is about
    assert result.outcome == "succeeded", (result.reason, result.success_detail)
    assert result.metrics["max_wrist_force_n"] < 20.0
