"""Injected faults: the `--fault` syntax, its diagnostics, determinism, and the fault matrices."""

from __future__ import annotations

import json

import pytest

from orchestrator.batch import fault_matrix
from orchestrator.batch.fault_matrix import MATRICES, RowResult, run_matrix
from orchestrator.engine.runner import run_episode
from orchestrator.language.bundled import bundled_names
from orchestrator.language.diagnostics import Diagnostic
from orchestrator.language.faults import FAULT_KINDS, parse_fault_spec
from orchestrator.language.load import load_scenario

# -- the spec syntax --------------------------------------------------------------------------


def test_a_fault_spec_at_a_time():
    assert parse_fault_spec("estop@1.5") == {"kind": "estop", "at": 1.5}


def test_a_fault_spec_on_entering_a_state_with_parameters_and_a_delay():
    spec = parse_fault_spec("push:object=cube,force_n=[0, 0, -150],duration_ms=20@TRANSPORT+0.2")
    assert spec == {
        "kind": "push",
        "object": "cube",
        "force_n": [0, 0, -150],
        "duration_ms": 20,
        "on_enter": "TRANSPORT",
        "delay_s": 0.2,
    }


@pytest.mark.parametrize("text", ["estop", "@1.0", "slip:factor@1.0", "estop@PICK+soon"])
def test_a_broken_fault_spec_is_a_diagnostic(text):
    diag = parse_fault_spec(text)
    assert isinstance(diag, Diagnostic) and diag.file == "<--fault>"


# -- user mistakes: exit 2, the fix in the message --------------------------------------------


@pytest.mark.parametrize(
    ("fault", "words"),
    [
        ("bogus@1.0", "estop"),  # the valid kinds are listed
        ("slip:object=ghost@1.0", "no scene object 'ghost'"),
        ("estop@NO.SUCH.STATE", "no state 'NO.SUCH.STATE'"),
        ("encoder_freeze:joint=9@1.0", "joint 9 is not an arm joint"),
        ("actuator_saturate:fraction=2@1.0", "fraction"),
        ("estop@1.0x", "no state '1.0x'"),
    ],
)
def test_bad_faults_exit_2_naming_the_option_and_the_fix(cli, fault, words):
    res = cli("run", "pick_place", "--fault", fault)
    assert res.exit_code == 2, res.stdout
    assert "<--fault>" in res.stderr and words in res.stderr
    assert "Traceback" not in res.stderr


def test_faults_in_a_scenario_file_are_located(write_yaml):
    path = write_yaml(
        "s.yaml",
        "name: s\nmachine: pick_place\nscene:\n  objects:\n"
        "    - {name: cube, size: [0.05, 0.05, 0.05], xy: [0.5, -0.12]}\n"
        "  markers: [{name: pad, xy: [0.5, 0.2]}]\n"
        "faults:\n  - {kind: slip, object: cube, at: 1.0, on_enter: TRANSPORT}\n",
    )
    with pytest.raises(Exception) as info:
        load_scenario(str(path))
    text = str(info.value)
    assert f"{path}:8:" in text and "exactly one of `at`" in text


def test_every_fault_kind_is_known_to_the_language():
    for kind in FAULT_KINDS:
        assert isinstance(parse_fault_spec(f"{kind}@1.0"), dict)


# -- behaviour --------------------------------------------------------------------------------


def test_the_same_seed_and_fault_give_the_same_result():
    loaded = load_scenario("pick_place", faults=["encoder_noise@PICK.GRASP.APPROACH+0.6"])
    a, b = run_episode(loaded, 4).to_json_dict(), run_episode(loaded, 4).to_json_dict()
    a.pop("wall_time"), b.pop("wall_time")
    assert a == b and a["reason"]["guard"] == "sensor_health"


def test_a_state_fault_starts_when_its_state_is_entered():
    result = run_episode(load_scenario("pick_place", faults=["estop@TRANSPORT+0.1"]), 3)
    entered = next(t["t"] for t in result.transitions if t["to"] == "TRANSPORT")
    assert result.metrics["faults"][0]["t"] == pytest.approx(entered + 0.1, abs=0.0021)


def test_a_perception_miss_is_retried_by_pick_place():
    result = run_episode(load_scenario("pick_place", faults=["perception_miss@0"]), 3)
    assert result.outcome == "succeeded" and result.retries["PICK"] >= 1
    assert result.transitions[0]["trigger"] == "not_found"


def test_a_slip_while_carrying_aborts_with_grasp_lost():
    result = run_episode(
        load_scenario("pick_place", faults=["slip:object=cube,factor=0.005@TRANSPORT"]), 3
    )
    assert result.outcome == "aborted" and result.reason["guard"] == "grasp_lost"


def test_a_slip_of_what_the_hand_holds_acts_on_the_object_in_the_hand():
    # `object: held` (parcels are drawn per seed): resolved by the fingers when it starts
    held = run_episode(
        load_scenario("pick_place", faults=["slip:object=held,factor=0.005@TRANSPORT"]), 3
    )
    named = run_episode(
        load_scenario("pick_place", faults=["slip:object=cube,factor=0.005@TRANSPORT"]), 3
    )
    assert held.reason == named.reason and held.reason["guard"] == "grasp_lost"
    # nothing in the hand: nothing to act on, said, and the run goes on
    empty = run_episode(load_scenario("pick_place", faults=["slip:object=held@0.05"]), 3)
    assert empty.outcome == "succeeded"


def test_a_fault_naming_no_object_lists_held_among_the_valid_ones(cli):
    res = cli("run", "pick_place", "--fault", "slip:object=nothing@0.5")
    assert res.exit_code == 2
    assert "no scene object 'nothing'" in res.stderr and "held" in res.stderr, res.stderr


def test_every_bundled_scenario_has_a_matrix_with_a_latency_for_each_guard_row():
    for name in bundled_names("scenarios"):
        rows = MATRICES[name]
        kinds = {r.fault.split("@")[0].split(":")[0] for r in rows}
        assert {"estop", "ft_dropout", "encoder_freeze", "actuator_lost"} <= kinds, name
        for r in rows:
            if r.expect and not r.expect.startswith("flow:"):
                assert r.within_s is not None and r.within_s > 0, (name, r)


@pytest.mark.slow
def test_the_mobile_search_fault_matrix_leaves_no_fault_undetected(cli):
    res = cli("faults", "mobile_search", "--json")
    rows = json.loads(res.stdout)
    assert res.exit_code == 0, [r for r in rows if not r["ok"]]
    assert not any(r["undetected"] for r in rows)


def test_the_pick_place_fault_matrix_is_caught_and_stopped_in_time(cli):
    res = cli("faults", "pick_place", "--json")
    assert res.exit_code == 0, res.stderr
    rows = json.loads(res.stdout)
    kinds = {row["fault"].split("@")[0].split(":")[0] for row in rows}
    assert kinds == set(FAULT_KINDS)  # every fault type has its row
    # how far the TCP moves from the violation to rest; 10 mm where the fault moves the arm
    # itself (a 150 N push on the held cube) or where its detection waits for the fingers,
    # which close at most at the hand's 0.05 m/s (an object slipping out: 0.15 s to close the
    # 5 mm grasp_lost watches for, the arm carrying on meanwhile; 7.4 mm)
    far = {"push": 10.0, "slip": 10.0}
    for row in rows:
        assert row["ok"], row
        if row["guard"] is not None:
            assert row["exit_code"] == 3 and row["outcome"] == "aborted"
            assert row["detect_s"] <= row["within_s"], row
            assert row["stop_time_s"] <= 0.15, row
            kind = row["fault"].split("@")[0].split(":")[0]
            assert row["stop_distance_mm"] <= far.get(kind, 5.0), row


@pytest.fixture(scope="module")
def surgical_matrix() -> list[RowResult]:
    """The surgical fault matrix (seed 0), run once for the tests that read it (~15 s)."""
    return run_matrix("surgical")


def _replay(monkeypatch: pytest.MonkeyPatch, rows: list[RowResult]) -> None:
    """`orchestrator faults` prints `rows` (the real matrix, already run) instead of rerunning."""

    def replay(scenario, seed=0, overrides=None, on_row=None) -> list[RowResult]:
        assert (seed, overrides) == (0, []), "the shared rows are seed 0's without overrides"
        for row in rows:
            if on_row is not None:
                on_row(row)
        return rows

    monkeypatch.setattr(fault_matrix, "run_matrix", replay)


@pytest.mark.slow  # 12 surgical episodes of ~40 s simulated each (the touch registration)
def test_the_surgical_fault_matrix_is_caught(cli, surgical_matrix, monkeypatch):
    _replay(monkeypatch, surgical_matrix)
    res = cli("faults", "surgical", "--json")
    assert res.exit_code == 0, res.stderr
    rows = json.loads(res.stdout)
    assert len(rows) == len(surgical_matrix)
    assert rows and all(row["ok"] for row in rows), [r for r in rows if not r["ok"]]
    for row in rows:
        if row["guard"] is not None:
            assert row["stop_time_s"] <= 0.15, row


@pytest.mark.slow  # shares the surgical matrix above
def test_the_fault_matrix_prints_a_table(cli, surgical_matrix, monkeypatch):
    _replay(monkeypatch, surgical_matrix)
    res = cli("faults", "surgical")
    assert res.exit_code == 0
    assert "estop" in res.stdout and "sensor_health" in res.stdout
    assert f"{len(surgical_matrix)} faults: {len(surgical_matrix)} as expected" in res.stdout


@pytest.mark.slow
def test_the_surgical_complication_fault_matrix_is_caught(cli):
    res = cli("faults", "surgical_complication")
    assert res.exit_code == 0
    assert "estop" in res.stdout and "sensor_health" in res.stdout


def test_a_fault_keyed_on_the_initial_state_fires():
    # no transition leads into the initial state: it is keyed on the state's entry instead
    # (a fault at `REACH+0.1` of the reach flow used to be silently never injected)
    result = run_episode(load_scenario("reach_random", faults=["estop@REACH+0.1"]), 0)
    assert result.outcome == "aborted" and result.reason["guard"] == "estop"
    assert result.metrics["faults"][0]["t"] == pytest.approx(0.1)
