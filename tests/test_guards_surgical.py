"""The surgical guards: `no_go_zone`, `path_deviation`, and `contact_force` on a zeroed sensor."""

from __future__ import annotations

import numpy as np
import pytest
from orchestrator.robots import Controller

from orchestrator.engine.blackboard import Blackboard
from orchestrator.engine.cell import Cell
from orchestrator.engine.context import Context
from orchestrator.engine.runner import run_episode
from orchestrator.guards import ContactForce, NoGoZone, PathDeviation
from orchestrator.guards.no_go_zone import UnknownZoneError
from orchestrator.language.load import load_scenario
from orchestrator.world import World
from orchestrator.world.path import PlannedPath

TIP_AT_HOME = np.array([0.30702, 0.0, 0.39027])
"""Where the probe tip of the surgical scenario is at home [m]."""


def _ctx(*overrides: str) -> Context:
    loaded = load_scenario("surgical", list(overrides))
    world = World.build(loaded.scenario, seed=0)
    ctrl = Controller(world.robot, float(world.model.opt.timestep))
    return Context(Cell(world, ctrl, 0), Blackboard())


def _guard(cls, ctx: Context, **params):
    guard = cls(cls.Params.model_validate(params))
    guard.bind(ctx)
    return guard


def _zone_at(center, size=(0.02, 0.02, 0.02)) -> list[str]:
    return [
        "scene.zones.vessel.frame=world",
        f"scene.zones.vessel.center={[float(v) for v in center]}",
        f"scene.zones.vessel.size={[float(v) for v in size]}",
    ]


# -- no_go_zone -------------------------------------------------------------------------------


def test_the_home_pose_is_where_these_tests_assume():
    ctx = _ctx()
    np.testing.assert_allclose(ctx.tcp_pos, TIP_AT_HOME, atol=1e-4)


def test_no_go_zone_is_quiet_while_the_robot_keeps_away():
    ctx = _ctx()  # the bundled vessel lies on the phantom, far below the arm at home
    assert _guard(NoGoZone, ctx).check(ctx) is None


def test_no_go_zone_fires_when_the_tool_enters_a_zone():
    ctx = _ctx(*_zone_at(TIP_AT_HOME))
    violation = _guard(NoGoZone, ctx).check(ctx)
    assert violation is not None and violation.guard == "no_go_zone"
    assert violation.value["zone"] == "vessel"
    assert violation.value["geom"].startswith("probe_")
    assert violation.value["distance_m"] <= 0.0
    assert "inside no-go zone 'vessel'" in violation.message


def test_no_go_zone_watches_the_arm_links_too():
    ctx = _ctx()
    elbow = ctx.data.xpos[ctx.model.body("panda_link4").id].copy()
    ctx = _ctx(*_zone_at(elbow, (0.03, 0.03, 0.03)))
    violation = _guard(NoGoZone, ctx).check(ctx)
    assert violation is not None
    assert not violation.value["geom"].startswith("probe_")


def test_no_go_zone_margin_fires_before_contact():
    # a 2 cm cube whose top is 6 mm below the tip
    ctx = _ctx(*_zone_at(TIP_AT_HOME - [0.0, 0.0, 0.016]))
    assert _guard(NoGoZone, ctx).check(ctx) is None
    violation = _guard(NoGoZone, ctx, margin_m=0.01).check(ctx)
    assert violation is not None
    assert violation.value["distance_m"] == pytest.approx(0.006, abs=2e-4)
    assert violation.limit == 0.01


def test_no_go_zone_names_the_valid_zones():
    ctx = _ctx()
    with pytest.raises(UnknownZoneError, match=r"no zone 'artery'.*valid: vessel"):
        _guard(NoGoZone, ctx, zones=["artery"])


def test_touching_the_no_go_zone_aborts_the_surgical_flow():
    # the vessel moved onto the incision line: the probe enters it on the way in
    loaded = load_scenario("surgical", ["scene.zones.vessel.center=[0.0, 0.0, 0.01]"])
    result = run_episode(loaded, 0)
    assert result.outcome == "aborted"
    assert result.reason["guard"] == "no_go_zone"
    assert result.reason["value"]["geom"].startswith("probe_")
    assert [t["to"] for t in result.transitions][-4:] == [
        "SAFE_HOLD.STOP",
        "SAFE_HOLD.BACK_OUT",
        "SAFE_HOLD.HELD",
        "ABORTED",
    ]


# -- path_deviation ---------------------------------------------------------------------------


def test_planned_path_distance_is_lateral_to_the_normal():
    path = PlannedPath(np.array([[0.0, 0.0, 0.0], [0.1, 0.0, 0.0]]), np.array([0.0, 0.0, -1.0]))
    assert path.deviation(np.array([0.05, 0.002, -0.004])) == pytest.approx(0.002)
    assert path.deviation(np.array([0.12, 0.0, 0.0])) == pytest.approx(0.02)  # past the end
    assert path.length == pytest.approx(0.1)


def test_planned_path_follows_every_segment():
    path = PlannedPath(np.array([[0.0, 0.0, 0.0], [0.1, 0.0, 0.0], [0.1, 0.1, 0.0]]))
    assert path.deviation(np.array([0.103, 0.05, 0.0])) == pytest.approx(0.003)
    assert path.deviation(np.array([0.1, 0.0, 0.004])) == pytest.approx(0.004)


def test_planned_path_points_by_distance_along_it():
    path = PlannedPath(np.array([[0.0, 0.0, 0.0], [0.1, 0.0, 0.0], [0.1, 0.1, 0.0]]))
    np.testing.assert_allclose(path.point_at(0.05), [0.05, 0.0, 0.0])
    np.testing.assert_allclose(path.point_at(0.15), [0.1, 0.05, 0.0])
    np.testing.assert_allclose(path.point_at(1.0), [0.1, 0.1, 0.0])  # clamped to the end


def test_a_path_needs_two_points():
    with pytest.raises(ValueError, match="at least 2 points"):
        PlannedPath(np.zeros((1, 3)))


def test_path_deviation_checks_only_while_a_path_is_published():
    ctx = _ctx()
    guard = _guard(PathDeviation, ctx, max_m=0.001)
    assert guard.check(ctx) is None  # nothing published
    normal = np.array([0.0, 0.0, -1.0])
    near = TIP_AT_HOME + [0.0, 0.0005, -0.005]  # 0.5 mm aside, 5 mm deeper: depth does not count
    ctx.planned_path = PlannedPath(np.array([near - [0.03, 0, 0], near + [0.03, 0, 0]]), normal)
    assert guard.check(ctx) is None
    far = TIP_AT_HOME + [0.0, 0.0015, 0.0]
    ctx.planned_path = PlannedPath(np.array([far - [0.03, 0, 0], far + [0.03, 0, 0]]), normal)
    violation = guard.check(ctx)
    assert violation is not None and violation.guard == "path_deviation"
    assert violation.value == pytest.approx(0.0015, abs=2e-5)
    assert "1.500 mm from the planned path exceeds 1.000 mm" in violation.message


# -- contact_force on a zeroed sensor ---------------------------------------------------------


def test_contact_force_sees_the_tool_weight_until_the_sensor_is_zeroed():
    ctx = _ctx("physics.realism.enabled=false")  # an exact sensor: the zeroing arithmetic
    weight = np.linalg.norm(ctx.wrist_force())
    assert weight == pytest.approx(0.25 * 9.81, rel=1e-3)  # the probe hangs on the wrist
    guard = _guard(ContactForce, ctx, max_n=1.0)
    assert guard.check(ctx) is not None
    ctx.zero_wrist_force(ctx.wrist_force().copy())
    assert np.linalg.norm(ctx.wrist_force()) < 1e-9
    assert guard.check(ctx) is None  # a guard bound before zeroing reads the zeroed sensor
