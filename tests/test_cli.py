"""The command line: exit codes, JSON contract, and user mistakes reported without tracebacks."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from .conftest import RESULT_KEYS

GOOD_MACHINE = """\
name: tiny
initial: SEARCH
blackboard: {object: cube}
states:
  SEARCH:
    skill: search
    with: {object: $object}
    transitions: {found: DONE, not_found: FAILED}
  DONE: {final: succeeded}
  FAILED: {final: failed}
"""


def _scenario(tmp_path: Path, machine_text: str) -> Path:
    (tmp_path / "m.yaml").write_text(machine_text)
    scenario = tmp_path / "s.yaml"
    scenario.write_text(
        "name: s\nmachine: m.yaml\n"
        "scene:\n  objects:\n    - {name: cube, size: [0.05, 0.05, 0.05], xy: [0.5, 0.0]}\n"
    )
    return scenario


def _assert_clean_error(res, file: str, line: int, *fragments: str) -> None:
    assert res.exit_code == 2, (res.stdout, res.stderr)
    assert res.exception is None, repr(res.exception)
    assert "Traceback" not in res.stderr + res.stdout
    pattern = re.compile(rf"{re.escape(file)}:{line}:\d+: ")
    lines = [ln for ln in res.stderr.splitlines() if pattern.search(ln)]
    assert lines, res.stderr
    for fragment in fragments:
        assert any(fragment in ln for ln in lines), (fragment, res.stderr)


def test_run_json_follows_the_contract(cli):
    res = cli("run", "pick_place", "--seed", "3", "--json")
    assert res.exit_code == 0, res.stderr
    data = json.loads(res.stdout)
    assert tuple(data)[: len(RESULT_KEYS)] == RESULT_KEYS
    assert data["scenario"] == "pick_place" and data["seed"] == 3
    assert data["outcome"] == "succeeded" and data["reason"] is None
    assert set(data["transitions"][0]) >= {"t", "from", "to", "trigger"}
    assert data["metrics"]["cycle_time"] <= 5.0
    assert data["success"]["cube_on_target"] is True


def test_run_human_output_summarizes(cli):
    res = cli("run", "pick_place", "--seed", "1")
    assert res.exit_code == 0
    assert "succeeded" in res.stdout and "PICK.GRASP.CLOSE" in res.stdout


def test_guard_violation_exits_3_with_guard_value_and_limit(cli):
    # shrink the workspace so that PLACE (pad at y = 0.2) leaves it
    res = cli(
        "run",
        "pick_place",
        "--json",
        "--set",
        "guards.workspace.max=[0.95, 0.1, 1.2]",
    )
    assert res.exit_code == 3, res.stderr
    data = json.loads(res.stdout)
    assert data["outcome"] == "aborted"
    reason = data["reason"]
    assert reason["guard"] == "workspace"
    assert reason["limit"] == {"axis": "y", "bound": 0.1}
    assert reason["value"][1] > 0.1
    assert "outside the workspace" in reason["message"]
    assert data["transitions"][-1]["trigger"] == "abort"
    assert data["transitions"][-1]["to"] == "SAFE_STOP"
    assert data["transitions"][-1]["from"] == "TRANSPORT"


def test_abort_stops_the_arm(pick_place):
    from orchestrator.engine.runner import run_episode
    from orchestrator.language.load import load_scenario

    class Speeds:
        def on_start(self, ctx, ex):
            self.after = []

        def on_tick(self, ctx, ex):
            if ex.violation is not None:
                self.after.append((ctx.t, float(abs(ctx.qd).max())))

        def on_end(self, ctx, ex, result):
            pass

    probe = Speeds()
    loaded = load_scenario("pick_place", ["guards.workspace.max=[0.95, 0.1, 1.2]"])
    result = run_episode(loaded, 0, [probe])
    assert result.outcome == "aborted"
    assert probe.after[-1][1] < 0.05  # at rest at the end of the safe stop


def test_unknown_state_names_the_valid_states(cli, tmp_path):
    text = GOOD_MACHINE.replace("found: DONE", "found: DNOE")
    res = cli("run", str(_scenario(tmp_path, text)))
    _assert_clean_error(
        res, str(tmp_path / "m.yaml"), 8, "unknown state 'DNOE'", "valid: SEARCH, DONE, FAILED"
    )


def test_unknown_skill_names_the_valid_skills(cli, tmp_path):
    text = GOOD_MACHINE.replace("skill: search", "skill: serach")
    res = cli("run", str(_scenario(tmp_path, text)))
    _assert_clean_error(
        res, str(tmp_path / "m.yaml"), 6, "unknown skill 'serach'", "move, move_joints"
    )


def test_unknown_parameter_names_the_valid_parameters(cli, tmp_path):
    text = GOOD_MACHINE.replace("with: {object: $object}", "with: {object: $object, colour: red}")
    res = cli("run", str(_scenario(tmp_path, text)))
    _assert_clean_error(
        res,
        str(tmp_path / "m.yaml"),
        7,
        "unknown key 'colour'",
        "valid: duration_s, into, near, near_radius_m, object",
    )


def test_yaml_syntax_error_names_the_line(cli, tmp_path):
    text = GOOD_MACHINE.replace("  DONE: {final: succeeded}", "  DONE: {final: succeeded")
    res = cli("run", str(_scenario(tmp_path, text)))
    _assert_clean_error(
        res,
        str(tmp_path / "m.yaml"),
        9,
        "the `{` opened at line 9, column 9 is not closed: add `}`",
    )


def test_on_instead_of_transitions_is_caught(cli, tmp_path):
    text = GOOD_MACHINE.replace("transitions: {found: DONE", "on: {found: DONE")
    res = cli("run", str(_scenario(tmp_path, text)))
    _assert_clean_error(res, str(tmp_path / "m.yaml"), 8, "states.SEARCH.on", "`transitions:`")


def test_all_errors_are_reported_at_once(cli, tmp_path):
    text = GOOD_MACHINE.replace("skill: search", "skill: serach").replace(
        "not_found: FAILED", "not_found: FIALED"
    )
    res = cli("validate", str(_scenario(tmp_path, text)))
    assert res.exit_code == 2
    assert "unknown skill 'serach'" in res.stderr and "unknown state 'FIALED'" in res.stderr


def test_unknown_set_key_is_invalid_input(cli):
    res = cli("run", "pick_place", "--set", "objekt=cube")
    assert res.exit_code == 2
    assert "<--set>" in res.stderr and "objekt" in res.stderr and "valid:" in res.stderr


def test_bad_set_value_type_is_invalid_input(cli):
    res = cli("run", "pick_place", "--set", "physics.control_hz=fast")
    assert res.exit_code == 2
    assert "physics.control_hz" in res.stderr


def test_unknown_scenario_lists_the_bundled_ones(cli):
    res = cli("run", "pick_plaec")
    assert res.exit_code == 2
    assert "(did you mean 'pick_place'?) (valid: grasp, home, mobile_search, pick_place" in (
        res.stderr
    )


def test_validate_accepts_the_bundled_files(cli):
    res = cli("validate", "pick_place")
    assert res.exit_code == 0, res.stderr
    repo = Path(__file__).resolve().parent.parent
    res = cli(
        "validate",
        str(repo / "machines" / "pick_place.yaml"),
        str(repo / "scenarios" / "pick_place.yaml"),
    )
    assert res.exit_code == 0, res.stderr
    assert "ok  machine" in res.stdout and "ok  scenario" in res.stdout


def test_list_shows_skills_guards_robots(cli):
    res = cli("list")
    assert res.exit_code == 0
    for name in (
        "pick_place",
        "move",
        "grasp",
        "search",
        "joint_limits",
        "workspace",
        "contact_force",
        "panda",
    ):
        assert name in res.stdout


@pytest.mark.parametrize("args", [["run", "pick_place", "--seed", "2", "--json"]])
def test_console_script_in_a_subprocess(cli_process, args):
    res = cli_process(*args)
    assert res.exit_code == 0, res.stderr
    assert json.loads(res.stdout)["outcome"] == "succeeded"


def test_invalid_input_in_a_subprocess_has_no_traceback(cli_process, tmp_path):
    text = GOOD_MACHINE.replace("skill: search", "skill: serach")
    res = cli_process("run", str(_scenario(tmp_path, text)))
    assert res.exit_code == 2
    assert "Traceback" not in res.stderr
    assert "unknown skill 'serach'" in res.stderr


@pytest.mark.parametrize(
    ("override", "fragment"),
    [
        ("hover=[.nan, 0, 0.1]", "[nan, 0, 0.1] is not finite: give finite numbers"),
        ("scene.objects.0.xy=[.nan, 0]", "finite number"),
        ("guards.contact_force.max_n=.inf", "finite number"),
    ],
)
def test_nan_and_inf_are_invalid_input(cli, override, fragment):
    res = cli("run", "pick_place", "--set", override)
    assert res.exit_code == 2 and res.exception is None
    assert fragment in res.stderr and "nothing was simulated" in res.stderr


def test_unknown_scene_names_are_caught_before_simulating(cli):
    res = cli("run", "pick_place", "--set", "place_at=padd")
    assert res.exit_code == 2
    assert "states.TRANSPORT.with.target: no object or marker 'padd'" in res.stderr
    # the same mistake in three states is said once, with the other lines
    assert re.search(
        r"\(the value of \$place_at\) \(3 places: also lines \d+, \d+\) \(valid: cube, pad\)",
        res.stderr,
    ), res.stderr
    assert "1 error; nothing was simulated" in res.stderr


def test_a_bad_value_met_while_running_stops_the_run_with_its_location(monkeypatch):
    # `run --set` refuses this value before anything moves (next test); a value that reaches
    # the blackboard another way (as if a skill had written it) is caught where it is used
    from orchestrator.engine.runner import run_episode
    from orchestrator.exceptions import ConfigError
    from orchestrator.language.load import load_scenario

    monkeypatch.setattr("orchestrator.language.load.all_finite", lambda value: True)
    monkeypatch.setattr("orchestrator.language.scenario_checks.check_values", lambda *a: [])
    with pytest.raises(ConfigError) as info:
        run_episode(load_scenario("pick_place", ["place_at=[0.5, 0.2, .inf]"]), 0)
    text = str(info.value)
    assert info.value.during_run
    assert "pick_place.yaml:" in text and "states.TRANSPORT: at t=" in text
    assert "finite number" in text and "pydantic" not in text  # no raw pydantic text or URL


def test_a_goal_that_is_not_finite_is_refused_before_the_run(cli):
    res = cli("run", "pick_place", "--set", "place_at=[0.5, 0.2, .inf]")
    assert res.exit_code == 2 and res.exception is None
    assert "blackboard.place_at: [0.5, 0.2, inf] is not finite: give finite numbers" in res.stderr
    assert "nothing was simulated" in res.stderr


@pytest.mark.parametrize(
    ("value", "message"),
    [
        ("NaN", "'NaN' is not finite: give finite numbers [m]"),
        ("[0.5, inf, 0.3]", "'inf' is not finite"),
        ("[0.5, 0.2, .nan]", "[0.5, 0.2, nan] is not finite"),
        ("[1e308, 0, 0.3]", "'1e308' is text, not a number"),
    ],
)
def test_a_goal_spelled_as_text_is_not_looked_up_as_a_name(cli, value, message):
    # YAML reads NaN, inf and 1e308 as text: once reported as "no object or marker 'NaN'"
    res = cli("run", "pick_place", "--set", f"place_at={value}")
    assert res.exit_code == 2 and res.exception is None
    assert f"<--set>: blackboard.place_at: {message}" in res.stderr
    assert "no object or marker" not in res.stderr
