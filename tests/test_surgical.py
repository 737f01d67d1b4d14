"""The surgical flow end to end: the tool, SETUP, the traced incision, and complications."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from orchestrator.robots import Controller, get_robot
from orchestrator.robots.tool import TIP_SITE

from orchestrator.engine.runner import run_episode
from orchestrator.language.load import load_scenario
from orchestrator.world import World, robot_only_model
from orchestrator.world.pose import rotation_of

from .test_physical_honesty import NoduleContacts, StepProbe, _complication

DEFAULT_SEEDS = [
    0,
    pytest.param(7, marks=pytest.mark.slow),
    pytest.param(13, marks=pytest.mark.slow),
]
"""Seed 0 in the default run; 7 and 13 (a surgical episode is 40 s simulated, ~7 s CPU) with
the slow suite, beside its 20-seed test."""
INCISION_M = 0.06


@pytest.fixture(scope="module")
def surgical():
    return load_scenario("surgical")


@pytest.fixture(scope="module")
def complication():
    return load_scenario("surgical_complication")


class Recorder:
    """Per control tick: state, time, tip, wrist force, joint speeds; the registration."""

    def on_start(self, ctx, executor):
        self.rows = []

    def on_tick(self, ctx, executor):
        f = ctx.wrist_force()
        self.rows.append(
            (
                executor.leaf,
                ctx.t,
                ctx.tcp_pos.copy(),
                float(np.linalg.norm(f)),
                np.abs(ctx.qd).max(),
            )
        )

    def on_end(self, ctx, executor, result):
        self.phantom = ctx.world.phantom
        self.registered = ctx.blackboard.get("phantom_pose")

    def where(self, state: str) -> list[tuple]:
        return [r for r in self.rows if r[0] == state]


def _check_success(result, rec: Recorder) -> None:
    assert result.outcome == "succeeded", (result.transitions, result.reason)
    m = result.metrics
    # the write-up's bar, against the true incision at every physics step (realism on:
    # friction, sensor noise and drift, quantized encoders): a deviation of 0.1 mm matters
    assert m["true_cross_track_max_mm"] <= 0.1
    assert m["true_cross_track_rms_mm"] <= 0.05
    # over the whole time the tip is in the tissue, the dwell at the start included (issue 42):
    # the touch-down's settling (0.3-0.4 N over the 2 N target, the loop's 0.15 s time
    # constant) adds ~0.03 N RMS to the 0.06-0.08 N of the lateral motion alone
    assert m["true_force_rms_error_n"] <= 0.15
    assert m["force_rms_error_n"] <= 0.1  # the skill's own, over the lateral motion
    assert m["peak_force_n"] <= 3.0
    assert m["path_deviation_max_mm"] <= 0.1  # against the registered line, per tick
    # the tip traced the whole line on the tissue: 6 cm along it, indented all the way
    trace = rec.where("EXECUTE.TRACE")
    start, end = trace[0][2], trace[-1][2]
    normal = rec.phantom.rotation[:, 2]
    along = end - start - float((end - start) @ normal) * normal
    assert np.linalg.norm(along) == pytest.approx(INCISION_M, abs=1e-3)
    surface = rec.phantom.surface_pos
    assert max(float((r[2] - surface) @ normal) for r in trace) < 0.0
    # the registered pose puts the incision within 30 um of where it really is, across it
    for local in ([-0.03, 0.0, 0.0], [0.03, 0.0, 0.0]):
        true = rec.phantom.rotation @ local + surface
        registered = rotation_of(rec.registered.quat) @ local + np.asarray(rec.registered.pos)
        side = rec.phantom.rotation[:, 1]
        assert abs(float((registered - true) @ side)) <= 0.03e-3


def _recorded(surgical, seed: int):
    rec = Recorder()
    return run_episode(surgical, seed, [rec]), rec


@pytest.fixture(scope="module")
def seed0_probed(surgical):
    """Seed 0's episode, its recorder and a per-physics-step probe (which reads no sensor),
    shared by the tests that read it (an episode: ~7 s CPU)."""
    rec, probe = Recorder(), StepProbe()
    return run_episode(surgical, 0, [rec, probe]), rec, probe


@pytest.fixture(scope="module")
def seed0(seed0_probed):
    return seed0_probed[:2]


@pytest.mark.parametrize("seed", DEFAULT_SEEDS)
def test_surgical_flow_traces_the_incision_at_2_n(surgical, seed0, seed):
    result, rec = seed0 if seed == 0 else _recorded(surgical, seed)
    _check_success(result, rec)
    states = [t["to"] for t in result.transitions]
    assert states == [
        "SETUP.INSTRUMENT",
        "SETUP.ZERO",
        "SETUP.LOCATE",
        "SETUP.ABOVE",
        "SETUP.REGISTER",
        "SETUP.READY",
        "NAVIGATE",
        "EXECUTE.CONTACT",
        "EXECUTE.TRACE",
        "EXECUTE.LIFT",
        "EXECUTE.RETRACT",
        "EXECUTE.EXECUTED",
        "DONE",
    ]


@pytest.mark.slow
def test_surgical_flow_over_20_seeds(surgical):
    outcomes, within = [], 0
    for seed in range(20):
        rec = Recorder()
        result = run_episode(surgical, seed, [rec])
        outcomes.append(result.outcome)
        m = result.metrics
        assert m["true_cross_track_rms_mm"] <= 0.05, (seed, m["true_cross_track_rms_mm"])
        assert m["true_force_rms_error_n"] <= 0.15, (seed, m["true_force_rms_error_n"])
        within += m["true_cross_track_max_mm"] <= 0.1
    assert outcomes.count("succeeded") >= 19, outcomes
    assert within >= 19


def test_surgical_figures_are_measured_against_the_true_incision(seed0):
    result, _ = seed0
    m = result.metrics
    assert result.outcome == "succeeded" and result.success["incision_traced"]
    # every physics step against the incision through the phantom's true pose: within the
    # write-up's 0.1 mm; the tip trails its setpoint along the path (not a path error)
    assert m["true_cross_track_max_mm"] <= 0.1
    assert m["true_cross_track_rms_mm"] <= 0.05
    assert 0.3 < m["along_track_lag_mean_mm"] < 3.0


def test_surgical_arm_stays_within_the_pandas_acceleration_limits(seed0_probed):
    _, _, probe = seed0_probed
    assert probe.accel <= 1.0, f"joint acceleration {probe.accel:.2f}x limit at {probe.accel_at}"


@pytest.mark.slow  # in the default run: pick_place's bit-for-bit test, the wrist sensor's noise
def test_same_seed_gives_the_same_result_bit_for_bit(surgical, seed0):
    a = seed0[0].to_json_dict()
    b = run_episode(surgical, 0, [Recorder(), StepProbe()]).to_json_dict()  # the same observers
    a.pop("wall_time"), b.pop("wall_time")
    assert a == b


@pytest.fixture(scope="module")
def complication_probed(complication):
    """The complication's seed 0, its recorder, a per-physics-step probe and the nodule's
    contacts (neither of the last two reads a sensor), shared by the tests that read it."""
    rec, probe, nodule = Recorder(), StepProbe(), NoduleContacts()
    return run_episode(complication, 0, [rec, probe, nodule]), rec, probe, nodule


@pytest.fixture(scope="module")
def complication_run(complication_probed):
    return complication_probed[:2]


@pytest.mark.slow  # in the default run: the same run's result below, and `run`'s exit 3 in test_cli
def test_complication_exits_3_naming_the_guard(cli):
    res = cli("run", "surgical_complication", "--json")
    assert res.exit_code == 3, res.stderr
    data = res.json
    assert data["outcome"] == "aborted"
    assert data["reason"]["guard"] == "contact_force"
    assert data["reason"]["limit"] == 5.0  # EXECUTE's own limit, not a run-wide one
    assert data["final_state"] == "ABORTED"


def test_complication_aborts_naming_the_guard(complication_run):
    data = complication_run[0].to_json_dict()
    assert data["outcome"] == "aborted"
    assert data["reason"]["guard"] == "contact_force"
    assert data["reason"]["limit"] == 5.0  # EXECUTE's own limit, not a run-wide one
    assert data["final_state"] == "ABORTED"


def test_complication_stops_the_arm_in_150_ms_then_holds_and_backs_out(complication_run):
    result, rec = complication_run
    assert result.outcome == "aborted"
    i = next(i for i, t in enumerate(result.transitions) if t["trigger"] == "abort")
    abort, stopped = result.transitions[i], result.transitions[i + 1]
    # the nodule trips the 5 N guard while tracing, or just after TRACE's own 4 N check
    # (filtered) ended it and ABANDON began backing off: which comes first depends on the
    # millisecond the tip meets the nodule (on main the CLI run abandons first, this test's
    # run, whose observer reads the noisy sensor, did not); either way the stop comes first
    assert abort["from"] in ("EXECUTE.TRACE", "EXECUTE.ABANDON"), abort
    assert abort["to"] == "SAFE_STOP"
    assert stopped["from"] == "SAFE_STOP" and stopped["to"] == "SAFE_HOLD.STOP"
    assert stopped["trigger"] == "stopped" and stopped["t"] - abort["t"] <= 0.15
    t_v = abort["t"]
    # stopped within 150 ms, and still for the rest of the 0.5 s hold
    hold = rec.where("SAFE_HOLD.STOP")
    assert hold[-1][1] - hold[0][1] == pytest.approx(0.5, abs=0.011)
    still = [r for r in hold if r[1] >= t_v + 0.15]
    assert still and max(r[4] for r in still) < 0.05
    # the tissue, relieved of the 2 N preload, may lift the tip a little against the hold
    tip = np.array([r[2] for r in still])
    assert np.linalg.norm(tip[-1] - tip[0]) < 0.5e-3
    # peak force: at the violation (physics step) and every tick to the end. The nodule is a
    # rigid box: the tip meeting it at the tracing speed is a one-step impact (9.2-9.6 N,
    # seeds 0-2), which the guard reads in that step, below the 10 N force ceiling
    assert result.reason["value"] <= 10.0
    after_contact = [r[3] for r in rec.rows if r[1] >= rec.where("EXECUTE.CONTACT")[0][1]]
    assert max(after_contact) <= 6.0
    # then backed out 2 cm along the tool axis (up): clear of the tissue
    back = rec.where("SAFE_HOLD.BACK_OUT")
    rise = back[-1][2][2] - hold[-1][2][2]
    assert rise == pytest.approx(0.02, abs=0.003)
    assert back[-1][3] < 0.1


def test_safe_hold_releases_the_nodule(complication_probed):
    result, _, probe, _ = complication_probed
    assert result.outcome == "aborted"
    t_abort = result.metrics["abort_t"]
    after = [f for t, f in probe.forces if t >= t_abort + 0.3]
    assert after, "the run ended at the abort"
    # the hold stops pushing: the tip rests on the tissue below the 2 N it traced with
    assert max(after) < 2.5, f"still {max(after):.2f} N on the nodule 0.3 s after the abort"


@pytest.mark.parametrize("seed", [0, pytest.param(11, marks=pytest.mark.slow)])
def test_only_the_tip_reaches_the_buried_nodule(complication_probed, seed):
    # the nodule is buried 0.5 mm under the surface (tests/test_tissue.py): the ball tip
    # pressed ~2 mm in meets it, the shaft (which ends at the tip's centre) never does
    if seed == 0:
        result, _, _, probe = complication_probed
    else:
        result, _, probe = _complication(seed)
    assert result.outcome == "aborted" and result.reason["guard"] == "contact_force"
    assert set(probe.touched) == {"probe_tip"}, probe.touched
    assert probe.touched["probe_tip"] > 1.0  # it ran into it, and that is what the guard saw


def test_setup_fails_without_the_instrument():
    result = run_episode(load_scenario("surgical", ["tool=null"]), 0)
    assert result.outcome == "failed"
    assert ("SETUP.NO_INSTRUMENT", "FAILED", "no_instrument") in [
        (t["from"], t["to"], t["trigger"]) for t in result.transitions
    ]


def test_setup_fails_when_the_registration_is_not_accurate_enough():
    # 1 cm perception noise: the fiducials no longer fit the phantom within 2 mm
    result = run_episode(load_scenario("surgical", ["perception.position_noise_m=0.01"]), 0)
    assert result.outcome == "failed"
    assert result.transitions[-1]["trigger"] == "not_registered"
    assert result.metrics["registration_fre_mm"] > 2.0


def test_setup_fails_when_another_instrument_is_mounted():
    result = run_episode(load_scenario("surgical", ["tool.name=scalpel"]), 0)
    assert result.outcome == "failed"
    assert result.transitions[-1]["trigger"] == "no_instrument"


def test_setup_weighs_the_instrument():
    # INSTRUMENT weighs it at 0.2 s, ZERO takes its offset by 0.6 s: the first second will do
    result = run_episode(
        load_scenario("surgical", ["tool.mass_kg=0.4", "physics.time_limit_s=1"]), 0
    )
    assert {"SETUP.INSTRUMENT", "SETUP.ZERO"} <= {t["from"] for t in result.transitions}
    assert result.metrics["tool_weight_n"] == pytest.approx(0.4 * 9.81, rel=1e-3)
    assert result.metrics["ft_offset_n"] == pytest.approx(0.4 * 9.81, rel=1e-3)


# -- the tool ---------------------------------------------------------------------------------


def test_the_tool_tip_is_the_tcp_for_mujoco_ik_and_the_controller(surgical):
    world = World.build(surgical.scenario, seed=0)
    robot = world.robot
    assert robot.tcp_site == TIP_SITE and robot.tcp_frame == TIP_SITE
    ctrl = Controller(robot)
    ik_model = robot_only_model(robot)
    assert ik_model.site(TIP_SITE).id >= 0
    rng = np.random.default_rng(0)
    m, d = world.model, world.data
    import mujoco

    for _ in range(5):
        d.qpos[world.arm_qpos] = world.home + rng.uniform(-0.5, 0.5, 7)
        mujoco.mj_forward(m, d)
        pos, rot = ctrl.tcp_pose(d.qpos[world.robot_qpos].copy())
        np.testing.assert_allclose(pos, d.site_xpos[world.tcp_site], atol=1e-9)
        np.testing.assert_allclose(rot, d.site_xmat[world.tcp_site].reshape(3, 3), atol=1e-9)
    # 20 cm from the flange, along its z axis
    flange = d.xpos[m.body("panda_link8").id]
    axis = d.xmat[m.body("panda_link8").id].reshape(3, 3)[:, 2]
    np.testing.assert_allclose(d.site_xpos[world.tcp_site], flange + 0.2 * axis, atol=1e-9)


def test_the_controller_model_carries_the_payload(surgical):
    robot = World.build(surgical.scenario, seed=0).robot
    bare = get_robot("panda").pinocchio_model()
    tooled = robot.pinocchio_model()
    assert sum(i.mass for i in tooled.inertias) - sum(i.mass for i in bare.inertias) == (
        pytest.approx(0.25)
    )
    q = pin.neutral(bare)
    g_bare = pin.computeGeneralizedGravity(bare, bare.createData(), q)
    g_tool = pin.computeGeneralizedGravity(tooled, tooled.createData(), q)
    assert np.abs(g_tool - g_bare).max() > 0.1  # it compensates the probe's weight


def test_no_tool_leaves_the_robot_as_it_was(pick_place):
    world = World.build(pick_place.scenario, seed=0)
    assert type(world.robot) is type(get_robot("panda"))
    assert world.robot.tcp_site == "tcp"
    assert robot_only_model(world.robot) is robot_only_model("panda")
    with pytest.raises(KeyError):
        robot_only_model("panda").site(TIP_SITE)
