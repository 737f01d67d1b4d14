"""`orchestrator explore`: parameters from the schema, seeded variations, the shrinker, and the
invariants every run measures."""

from __future__ import annotations

import json

import pytest

from orchestrator.engine.invariants import InvariantsObserver
from orchestrator.engine.runner import new_run
from orchestrator.exceptions import ConfigError
from orchestrator.explore.campaign import load_space
from orchestrator.explore.params import override_texts
from orchestrator.explore.sampler import draw_variations
from orchestrator.explore.shrink import shrink
from orchestrator.explore.verdict import failures, primary
from orchestrator.language.load import load_scenario, load_world
from orchestrator.language.scenario import ObjectSpec

from .cli_runner import invoke


@pytest.fixture(scope="module")
def space():
    return load_space("pick_place")


def test_parameters_are_the_schema_s_validated_ranges(space):
    by_path = space.by_path
    mass = by_path["scene.objects.cube.mass"]
    ge, le = (m for m in ObjectSpec.model_fields["mass"].metadata)
    assert (mass.lo, mass.hi, mass.nominal) == (ge.ge, le.le, 0.1)
    # a randomization range is explored element by element, within the coordinate's bounds
    assert by_path["scene.objects.cube.randomize.x.1"].nominal == 0.08
    # every parameter can be set at its nominal value: it is a `--set` path of the scenario
    # (an element of a list the file leaves at its default, the cube's colour, by the list)
    for p in space.params:
        assert space.accepts(override_texts({p.path: p.nominal}, space.by_path)), p.path
    assert space.by_path["scene.objects.cube.rgba.0"].whole is not None


def test_items_the_loader_generates_are_not_explored():
    paths = [p.path for p in load_space("sorting").params]
    assert "scene.parcels.mass_kg.1" in paths and "scene.bins.bin_A.wall_height_m" in paths
    assert not [p for p in paths if "_wall_" in p]  # a bin's walls are made from the bin


def test_the_same_seed_draws_the_same_variations(space):
    a = draw_variations(space.params, 12, seed=7, accepts=space.accepts)
    b = draw_variations(space.params, 12, seed=7, accepts=space.accepts)
    c = draw_variations(space.params, 12, seed=8, accepts=space.accepts)
    assert [v.to_dict() for v in a] == [v.to_dict() for v in b]
    assert [v.values for v in a] != [v.values for v in c]
    assert len({v.seed for v in a}) == len(a)
    # every variation is one validation accepts, and each moves 1 to 3 parameters
    fresh = load_space("pick_place")
    assert all(fresh.accepts(v.overrides(fresh.by_path)) and 1 <= len(v.values) <= 3 for v in a)


def test_a_stated_share_of_values_sits_at_the_edges(space):
    draws = draw_variations(space.params, 60, seed=3, accepts=lambda _: True)
    by_path = space.by_path
    values = [(by_path[p], x) for v in draws for p, x in v.values.items()]
    numeric = [(p, x) for p, x in values if not p.choices]
    at_edge = sum(1 for p, x in numeric if x in (p.lo, p.hi, round(p.lo, 6), round(p.hi, 6)))
    assert 0.1 <= at_edge / len(numeric) <= 0.5, at_edge / len(numeric)
    assert any(v.kind == "corner" for v in draws)


def test_the_shrinker_reduces_a_planted_defect_to_its_one_parameter(space):
    by_path = space.by_path
    mass = by_path["scene.objects.cube.mass"]
    limit = 2.0  # the planted defect: the cell fails for any cube heavier than 2 kg
    asked = []

    def fails(candidates):
        asked.extend(candidates)
        return [float(c.get(mass.path, mass.nominal)) > limit for c in candidates]

    drawn = {
        "scene.objects.cube.friction": 0.3,
        mass.path: 87.5,
        "scene.markers.pad.rgba.0": 0.9,
    }
    shrunk = shrink(drawn, by_path, fails)
    assert list(shrunk.values) == [mass.path]
    step = (87.5 - mass.nominal) / 2**6
    assert limit < shrunk.values[mass.path] <= limit + step  # as close to nominal as fails
    assert shrunk.runs == len(asked)


def test_a_failure_at_nominal_shrinks_to_no_parameter(space):
    shrunk = shrink({"scene.objects.cube.friction": 0.3}, space.by_path, lambda c: [True] * len(c))
    assert shrunk.values == {}


def test_a_result_line_is_filed_under_its_first_invariant_violation():
    line = {
        "outcome": "aborted",
        "success": {"cube_on_target": False},
        "invariants": {"ok": False, "violations": [
            {"invariant": "finger_speed", "t": 2.0}, {"invariant": "joint_acceleration", "t": 1.5},
        ]},
    }  # fmt: skip
    assert failures(line) == [
        "invariant:finger_speed", "invariant:joint_acceleration", "check:cube_on_target"
    ]  # fmt: skip
    assert primary(line) == "invariant:joint_acceleration"
    refused = {"outcome": "error", "error": {"type": "ConfigError"}}
    assert failures(refused) == [] and primary(refused) is None


def test_the_observer_names_a_joint_over_its_datasheet_speed_and_when():
    run = new_run(load_scenario("pick_place"), 0)
    obs = InvariantsObserver()
    run.episode.start()
    obs.on_start(run.ctx, run.executor)
    dof = run.ctx.world.arm_dof
    limit = run.ctx.robot.joint_velocity_limits()[3]
    run.ctx.data.qvel[dof[3]] = 1.5 * limit
    obs.on_step(run.ctx)
    (v,) = [v for v in obs.violations if v["invariant"] == "joint_velocity"]
    assert v["value"] == pytest.approx(1.5 * limit, rel=1e-6) and v["limit"] == pytest.approx(limit)
    assert "joint 4" in v["message"] and v["state"] == run.executor.leaf
    # the same step's jump from rest is also an acceleration far over the datasheet
    assert any(v["invariant"] == "joint_acceleration" for v in obs.violations)
    run.ctx.data.qvel[:] = 0.0
    before = len(obs.violations)
    obs.on_step(run.ctx)  # back at rest: the deceleration is a new step over, same joint: once
    assert len(obs.violations) == before


@pytest.mark.parametrize("scenario", ["pick_place", "pick_place_so101"])
def test_the_fingers_speed_is_judged_in_metres_per_second_for_a_slide_or_a_jaw(scenario):
    # the SO-101's revolute jaw moves in rad/s: read as m/s, its nominal 1.42 rad/s (0.048 m/s
    # at the jaw's face) was 1.42 m/s against the 0.05 m/s limit, and every run failed --strict
    run = new_run(load_scenario(scenario), 0)
    obs = InvariantsObserver()
    run.episode.start()
    obs.on_start(run.ctx, run.executor)
    robot, model, data = run.ctx.robot, run.ctx.model, run.ctx.data
    finger = int(model.jnt_dofadr[model.joint(robot.finger_joints[0]).id])
    per_m = 1.0 / robot.finger_m_per_unit  # joint units per metre of the finger's travel
    data.qvel[finger] = 0.95 * robot.gripper_speed_mps * per_m
    obs.on_step(run.ctx)
    assert not [v for v in obs.violations if v["invariant"] == "finger_speed"]
    assert obs.worst_f == pytest.approx(0.95, rel=1e-6)
    data.qvel[finger] = 1.2 * robot.gripper_speed_mps * per_m
    obs.on_step(run.ctx)
    (v,) = [v for v in obs.violations if v["invariant"] == "finger_speed"]
    assert v["value"] == pytest.approx(1.2 * robot.gripper_speed_mps, rel=1e-4)


def test_every_run_reports_its_invariants_and_strict_keeps_exit_zero_when_they_hold():
    result = invoke(["run", "reach_random", "--json", "--strict"])
    assert result.exit_code == 0, result.output
    data = json.loads(result.stdout)
    inv = data["invariants"]
    assert inv["ok"] and inv["violations"] == []
    assert 0.0 < inv["worst"]["joint_acceleration"] <= 1.0
    assert 0.0 < inv["worst"]["joint_velocity"] <= 1.0


def test_strict_exits_1_naming_the_invariant_a_run_violated(monkeypatch):
    start = InvariantsObserver.on_start

    def tenth_of_the_datasheet(self, ctx, executor):  # the arm's speed limit read 10x lower
        start(self, ctx, executor)
        self.vlim = 0.1 * self.vlim
        self.inv_v = (1.0 / self.vlim).tolist()

    monkeypatch.setattr(InvariantsObserver, "on_start", tenth_of_the_datasheet)
    plain = invoke(["run", "reach_random", "--json"])
    assert plain.exit_code == 0, plain.output  # without --strict: the run's own exit code
    assert not json.loads(plain.stdout)["invariants"]["ok"]
    strict = invoke(["run", "reach_random", "--json", "--strict"])
    assert strict.exit_code == 1, strict.output
    assert "invariant joint_velocity violated" in strict.stderr


def test_replay_names_the_valid_counterexamples(tmp_path):
    (tmp_path / "counterexamples.jsonl").write_text(
        json.dumps({"k": 4, "seed": 1, "set": [], "violated": "check:x", "message": ""}) + "\n"
    )
    (tmp_path / "explore.json").write_text(json.dumps({"scenario_ref": "pick_place"}))
    result = invoke(["explore", "pick_place", "--out", str(tmp_path),
                                      "--replay", "3"])  # fmt: skip
    assert result.exit_code == 2
    assert "no counterexample 3" in result.output and "valid: 4" in result.output


def test_a_scene_inside_the_arm_s_start_pose_is_refused_before_anything_moves():
    # explore's first class on reach_random: a table raised into the home pose was accepted
    # and the first physics step threw the arm out at 24 rad/s (joint_velocity, t=0.002 s)
    with pytest.raises(ConfigError) as caught:
        load_world("reach_random", 0, ["scene.table.height=0.49"])
    (diag,) = caught.value.diagnostics
    assert diag.path == "scene" and "inside table_top" in diag.message
    assert "scene.table.height" in diag.message  # the fix is named
    load_world("reach_random", 0, ["scene.table.height=0.45"])  # clear of the arm: accepted


@pytest.mark.parametrize(
    ("sets", "said"),
    [
        # explore on pick_place: the cube randomized up to 10 m off fell beside the table
        (["scene.objects.cube.randomize.y=[-0.08, 10.0]"], "off the table top"),
        # a pad on the table, 5.4 m from the arm (explore drew one 9.4 m away)
        (
            [
                "scene.table.center_xy=[3.0, 0.0]",
                "scene.table.size_xy=[10.0, 0.9]",
                "scene.markers.pad.xy=[5.4, 0.2]",
            ],
            "beyond its reach",
        ),
    ],
)
def test_a_table_top_object_or_marker_out_of_the_cell_is_refused(sets, said):
    with pytest.raises(ConfigError) as caught:
        load_scenario("pick_place", sets)
    assert any(said in d.message and d.path.startswith("scene.") for d in caught.value.diagnostics)


def test_a_pick_area_off_the_table_is_refused():
    # explore on sorting: the pick area 6.5 m off; its parcels fell to the floor under no task
    with pytest.raises(ConfigError) as caught:
        load_scenario("sorting", ["scene.parcels.area_center_xy=[6.45, -0.2]"])
    (diag,) = caught.value.diagnostics
    assert diag.path.startswith("scene.parcels") and "the pick area" in diag.message
    assert "off the table top" in diag.message
