"""One rule for what a SCENARIO or MACHINE argument names (language/entries.py): a file, else
a bundled scenario, else a bundled machine (in the default scene), else an error with the
closest name. `orchestrator run reach` once said "running it in the default scene" and then
"no such scenario"."""

from __future__ import annotations

from pathlib import Path

import pytest

from orchestrator.language.bundled import bundled_path
from orchestrator.language.entries import entry_file, entry_note
from orchestrator.language.load import load_scenario

REPO = Path(__file__).resolve().parent.parent


def test_a_bundled_scenario_name_is_the_scenario():
    assert entry_file("pick_place") == bundled_path("scenarios", "pick_place")
    assert load_scenario("surgical_complication").scenario.name == "surgical_complication"
    assert entry_note("pick_place") is None


def test_a_bundled_machine_only_runs_in_the_default_scene(cli):
    res = cli("run", "reach", "--json")
    assert res.exit_code == 0, res.stderr
    assert "reach is a machine: running it in the default scene" in res.stderr
    assert "no such" not in res.stderr
    assert res.json["scenario"] == "reach" and res.json["outcome"] == "succeeded"
    assert load_scenario("reach").scenario.scene.objects[0].name == "cube"  # the default scene


def test_a_path_is_that_file(tmp_path):
    (tmp_path / "cell.yaml").write_text("name: cell\nmachine: reach\n")
    assert entry_file(str(tmp_path / "cell.yaml")) == tmp_path / "cell.yaml"
    assert load_scenario(str(tmp_path / "cell.yaml")).scenario.name == "cell"


def test_a_file_named_like_a_bundled_one_wins_and_the_user_is_told(cli, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "pick_place").write_text((REPO / "machines" / "reach.yaml").read_text())
    assert load_scenario("pick_place").machine.name == "reach"  # the file, not the bundled
    assert entry_note("pick_place") == (
        "pick_place is the file ./pick_place here, not the bundled scenario of that name (run "
        "it from another folder to get the bundled one)"
    )
    res = cli("graph", "pick_place")
    assert res.exit_code == 0 and "REACH" in res.stdout
    assert "note: pick_place is the file ./pick_place here" in res.stderr
    (tmp_path / "pick_place").unlink()
    (tmp_path / "pick_place.yaml").write_text((REPO / "machines" / "reach.yaml").read_text())
    assert load_scenario("pick_place").machine.name == "pick_place"  # the bundled one
    assert entry_note("pick_place") == (
        "pick_place is the bundled scenario; the file ./pick_place.yaml here is not used (pass "
        "./pick_place.yaml, with its path, to use it)"
    )


@pytest.mark.parametrize(
    "args",
    [["run", "reahc"], ["batch", "reahc", "-n", "1"], ["faults", "reahc"], ["graph", "reahc"],
     ["validate", "reahc"]],
    ids=lambda a: a[0],
)  # fmt: skip
def test_an_unknown_name_says_did_you_mean(cli, tmp_path, monkeypatch, args):
    monkeypatch.chdir(tmp_path)
    res = cli(*args)
    assert res.exit_code == 2 and res.exception is None
    if args[0] == "validate":  # it names files too: its own wording, the same names
        assert "reahc: <file>: no such file, bundled scenario or machine" in res.stderr
        return
    assert "reahc: <" in res.stderr
    assert (
        "no such scenario or machine: not a file, a bundled scenario or a bundled machine (did "
        "you mean 'reach'?)"
    ) in res.stderr
    assert "pick_place" in res.stderr  # the valid names
    assert not (tmp_path / "runs").exists()  # batch made no directory


def test_graph_of_a_bundled_scenario_draws_its_machine(cli):
    res = cli("graph", "surgical_complication")
    assert res.exit_code == 0, res.stderr
    assert "NAVIGATE" in res.stdout  # the surgical machine
