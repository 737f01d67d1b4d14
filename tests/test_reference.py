"""Reference pages are generated from the code and in sync; `list` and `show` print them;
the CLI's small courtesies (version, where the recording went, unwrapped piped output)."""

from __future__ import annotations

from pathlib import Path

import pytest

from orchestrator.language.reference import (
    DOCS_DIR,
    param_rows,
    scenario_reference,
    skills_reference,
)
from orchestrator.language.scenario import Scenario
from orchestrator.success import CHECKS, bundled_check_kinds
from orchestrator.success.params import CheckParams

REPO = Path(__file__).resolve().parent.parent
MACHINE = """\
name: home_only
initial: HOME
states:
  HOME:
    skill: move_joints
    with: {to: home}
    transitions: {reached: DONE, timeout: FAILED}
  DONE: {final: succeeded}
  FAILED: {final: failed}
"""


@pytest.mark.parametrize(
    ("page", "generate"),
    [("skills.md", skills_reference), ("scenario-reference.md", scenario_reference)],
)
def test_generated_reference_pages_are_not_stale(page, generate):
    assert (DOCS_DIR / page).read_text() == generate(), (
        f"docs/{page} is stale: run `python -m orchestrator.language.reference`"
    )


def _all_models(model, seen=None):
    seen = seen if seen is not None else set()
    if model not in seen:
        seen.add(model)
        for row in param_rows(model):
            if row.model is not None and row.model is not CheckParams:  # per kind: skills.md
                _all_models(row.model, seen)
    return seen


def test_the_skills_page_has_every_key_of_every_success_check():
    text = skills_reference()
    for kind in bundled_check_kinds():
        assert f"## `{kind}`" in text
        for name in CHECKS[kind].Params.model_fields:
            assert name == "kind" or f"| `{name}` |" in text, f"{kind}.{name}"
    assert "| `gap_tol_m` | float | m | `0.003` | > 0, ≤ 0.1 |" in text


def test_the_scenario_reference_has_every_key_of_every_scenario_model():
    text = scenario_reference()
    models = _all_models(Scenario)
    assert len(models) >= 10
    for model in models:
        for name in model.model_fields:
            assert f"| `{name}` |" in text, f"{model.__name__}.{name}"
    for section in ("## `scene`", "## `scene.objects[]`", "## `physics.safe_stop`"):
        assert section in text
    assert "| `time_limit_s` | float | s | `30.0` | > 0, ≤ 86400 |" in text


def test_show_skill_prints_parameters_with_type_unit_default_and_range(cli):
    res = cli("show", "skill", "move")
    assert res.exit_code == 0
    assert "| `tolerance_m` | float | m | `0.001` | > 0 | Position tolerance |" in res.stdout
    assert "| `max_speed` | float | m/s | `0.5` | > 0, ≤ 2 |" in res.stdout
    assert "| `target` | any |  | required |" in res.stdout
    assert "Outcomes: `reached`, `unreachable`, `timeout` (success: `reached`)." in res.stdout


def test_show_skill_says_what_it_writes_to_the_blackboard(cli):
    res = cli("show", "skill", "search")
    assert "Writes to the blackboard: the key named by `into` (a pose)." in res.stdout


def test_show_guard_and_show_scenario(cli):
    res = cli("show", "guard", "contact_force")
    assert res.exit_code == 0 and "| `max_n` |" in res.stdout
    res = cli("show", "scenario", "pick_place")
    assert res.exit_code == 0
    assert '| `place_at` | any | "pad" | machine `pick_place` |' in res.stdout
    assert (
        '* `cube_on_target`: object_at (object "cube", target "$place_at", xy_tol_m 0.01, '
        "upright_tol_deg 10.0)" in res.stdout
    )


def test_show_scenario_shows_the_values_the_scenario_really_uses(cli):
    # sorting's own defaults, not those of the grasp machine it includes (outer levels win)
    res = cli("show", "scenario", "sorting")
    assert res.exit_code == 0
    assert "| `approach_speed` | float | 0.6 | machine `sorting` |" in res.stdout
    assert '| `object` | str | "*" | machine `sorting` |' in res.stdout
    assert "| `yaw_symmetry_deg` | float | 180.0 | machine `sorting` |" in res.stdout
    assert "| `lift` | vec3 | [0.0, 0.0, 0.05] | machine `grasp` |" in res.stdout


def test_show_scenario_shows_a_value_the_scenario_sets(cli, tmp_path: Path):
    text = (REPO / "scenarios" / "pick_place.yaml").read_text()
    (tmp_path / "s.yaml").write_text(text + "blackboard: {place_at: [0.4, 0.25, 0.2]}\n")
    res = cli("show", "scenario", str(tmp_path / "s.yaml"))
    assert res.exit_code == 0, res.stderr
    assert "| `place_at` | any | [0.4, 0.25, 0.2] | this scenario |" in res.stdout


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (("show", "skill", "mvoe"), "unknown skill 'mvoe' (did you mean 'move'?) (valid: "
         "approach, check_tool, contact,"),
        (("show", "robot", "pnada"), "unknown robot 'pnada' (did you mean 'panda'?) (valid: "
         "mobile_panda, panda,"),
        (("show", "arm", "panda"), "unknown kind 'arm' (valid: skill, check, guard, "),
        (("show", "check", "stakced"), "unknown check 'stakced' (did you mean 'stacked'?) "
         "(valid: gripper_clear, held,"),
        (("list", "skils"), "unknown list 'skils' (did you mean 'skills'?) (valid: scenarios, "
         "machines, skills,"),
    ],
)  # fmt: skip
def test_show_and_list_reject_unknown_names_with_the_valid_ones(cli, args, message):
    res = cli(*args)
    assert res.exit_code == 2 and message in res.stderr, res.stderr


def test_list_skills_lists_only_skills(cli):
    res = cli("list", "skills")
    assert res.exit_code == 0
    assert "move " in res.stdout and "scenarios" not in res.stdout


def test_version(cli, monkeypatch):
    res = cli("--version")
    assert res.exit_code == 0 and res.stdout.startswith("orchestrator 0.")
    assert "(physics step: compiled)" in res.stdout or "(physics step: pure Python)" in res.stdout
    monkeypatch.setenv("ORCHESTRATOR_PURE_PYTHON", "1")  # says which path the user gets
    assert "(physics step: pure Python)" in cli("--version").stdout


def test_run_takes_a_machine_file_in_the_default_scene(cli_process, tmp_path: Path):
    (tmp_path / "home_only.yaml").write_text(MACHINE)
    res = cli_process("run", "home_only.yaml", "--rrd", "out.rrd", cwd=tmp_path)
    assert res.exit_code == 0, res.stderr
    assert "home_only.yaml is a machine: running it in the default scene" in res.stderr
    assert "recording saved to out.rrd (open it with: rerun out.rrd)" in res.stderr
    assert (tmp_path / "out.rrd").stat().st_size > 0
    # piped to a file: the summary line is not wrapped at 80 columns
    first = res.stdout.splitlines()[0]
    assert first.startswith("home_only seed 0: succeeded in DONE") and first.endswith("real time)")


def test_graph_of_a_scenario_draws_its_machine(cli, tmp_path: Path):
    (tmp_path / "m.yaml").write_text(MACHINE)
    (tmp_path / "s.yaml").write_text("name: s\nmachine: m.yaml\n")
    res = cli("graph", str(tmp_path / "s.yaml"))
    assert res.exit_code == 0
    assert "is a scenario: drawing its machine 'm.yaml'" in res.stderr
    assert "HOME" in res.stdout


def test_graph_of_a_broken_machine_does_not_say_nothing_was_simulated(cli, tmp_path: Path):
    (tmp_path / "m.yaml").write_text(MACHINE.replace("initial: HOME", "initial: HOM"))
    res = cli("graph", str(tmp_path / "m.yaml"))
    assert res.exit_code == 2
    assert "nothing was drawn" in res.stderr and "simulated" not in res.stderr


def test_the_scenario_reference_example_is_a_valid_scenario(tmp_path: Path):
    import yaml

    from orchestrator.language.load import load_scenario
    from orchestrator.language.reference import _EXAMPLE

    data = yaml.safe_load(_EXAMPLE)
    assert data["success"]["cube_placed"]["target"] == "$place_at"
    data["machine"] = "pick_place"  # the example's own machine is the tutorial's
    data.pop("skills")
    (tmp_path / "s.yaml").write_text(yaml.safe_dump(data))
    loaded = load_scenario(str(tmp_path / "s.yaml"))
    assert loaded.scenario.success["cube_placed"].xy_tol_m == 0.01


def test_the_skills_page_lists_only_shipped_skills_and_guards():
    # tests register a `scripted` skill and a `flag` guard in the same process
    from tests.scripted import register

    register()
    text = skills_reference()
    assert "`scripted`" not in text and "`flag`" not in text
    assert text == (DOCS_DIR / "skills.md").read_text()
