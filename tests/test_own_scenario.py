"""A scenario of one's own, as the docs teach it: its skill folders on every command (`--skills`
on `batch` and `faults` as on `run`), and a fault matrix that says what its guards cannot see."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import pytest

from orchestrator.batch.fault_matrix import blind_kinds, matrix_for
from orchestrator.batch.summary import rerun_command
from orchestrator.language.load import load_scenario

DOCS = Path(__file__).resolve().parents[1] / "docs"


def _doc_files(tmp_path: Path) -> Path:
    """docs/success-checks.md's files (the `stack` scenario and its `aligned` check), with the
    scenario renamed and its `skills:` line dropped: the check folder comes from `--skills`."""
    text = (DOCS / "success-checks.md").read_text()
    for name, body in re.findall(r"<!-- file: (\S+) -->\n```\w+\n(.*?)```", text, re.S):
        path = tmp_path / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(body)
    cell = (tmp_path / "stack_cell.yaml").read_text()
    cell = re.sub(r"^skills: .*\n", "", cell, flags=re.M).replace("name: stack\n", "name: mine\n")
    (tmp_path / "mine.yaml").write_text(cell)
    return tmp_path / "mine.yaml"


# the CLI runs in its own process here: a check folder registered in this one would stay


@pytest.mark.slow  # a batch in a process of its own (~7 s)
def test_batch_takes_skills_for_its_workers_and_its_rerun_command(cli_process, tmp_path):
    scenario = _doc_files(tmp_path)
    out = tmp_path / "b"
    args = ("batch", str(scenario), "-n", "1", "--workers", "1", "--record", "none")
    refused = cli_process(*args, "--out", str(tmp_path / "a"))
    assert refused.exit_code == 2 and "aligned" in refused.stderr  # the check is unknown
    res = cli_process(*args, "--out", str(out), "--skills", str(tmp_path / "my_checks"), "--json")
    assert res.exit_code == 0, res.stderr
    line = json.loads((out / "results.jsonl").read_text().splitlines()[0])
    assert line["outcome"] != "error", line.get("error")
    assert "turned_alike" in line["success"]  # the folder's check judged the episode
    command = rerun_command(str(scenario), [], 3, skill_paths=[str(tmp_path / "my_checks")])
    assert f"--skills {tmp_path / 'my_checks'}" in command


def test_a_fresh_worker_registers_the_batch_skills_before_loading(tmp_path):
    # a worker process that never saw the CLI's registration (a Ray worker, a fork server
    # started earlier) loads the scenario with the task's `--skills` paths
    scenario = _doc_files(tmp_path)
    code = (
        "import sys\n"
        "from orchestrator.batch.episode import run_task\n"
        "from orchestrator.batch.task import EpisodeTask\n"
        "line = run_task(EpisodeTask(sys.argv[1], ('physics.time_limit_s=0.2',), 0,\n"
        "    skill_paths=(sys.argv[2],)))\n"
        "print(line['outcome'], (line.get('error') or {}).get('message', ''))\n"
    )
    proc = subprocess.run(
        [sys.executable, "-c", code, str(scenario), str(tmp_path / "my_checks")],
        capture_output=True, text=True, timeout=300, check=False,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    assert not proc.stdout.startswith("error"), proc.stdout


def test_faults_takes_skills(cli_process, tmp_path):
    scenario = _doc_files(tmp_path)
    res = cli_process(
        "faults", str(scenario), "--skills", str(tmp_path / "my_checks"), "--json",
        "--set", "physics.time_limit_s=0.05",
    )  # fmt: skip
    assert res.exit_code != 2, res.stderr
    assert "unknown success check" not in res.stderr
    assert json.loads(res.stdout)  # the rows


TINY = """\
name: tiny
initial: LOOK
blackboard: {object: cube}
guards: [joint_limits]
states:
  LOOK:
    skill: search
    with: {object: $object}
    transitions: {found: DONE, not_found: FAILED}
  DONE: {final: succeeded}
  FAILED: {final: failed}
"""


def _tiny(tmp_path: Path, guards: str = "") -> Path:
    (tmp_path / "m.yaml").write_text(TINY)
    path = tmp_path / "s.yaml"
    path.write_text(
        "name: tiny_cell\nmachine: m.yaml\n"
        "scene:\n  objects:\n    - {name: cube, size: [0.05, 0.05, 0.05], xy: [0.5, 0.0]}\n"
        + guards
    )
    return path


def test_the_kinds_a_scenario_cannot_see_are_the_ones_without_their_guard(tmp_path):
    bare = load_scenario(str(_tiny(tmp_path)))
    blind = blind_kinds(bare, matrix_for(bare.name))
    assert blind["ft_dropout"] == ("sensor_health",) and blind["ft_bias"] == ("contact_force",)
    assert "estop" not in blind  # every machine has the emergency stop
    assert "perception_miss" not in blind  # the flow's to handle, not a guard's
    guarded = load_scenario(str(_tiny(tmp_path, "guards: {sensor_health: {}}\n")))
    assert set(blind_kinds(guarded, matrix_for(guarded.name))) == {"ft_bias"}
    for name in ("pick_place", "stack", "sorting"):  # the bundled ones see every fault they get
        loaded = load_scenario(name)
        assert blind_kinds(loaded, matrix_for(name)) == {}, name


def test_faults_on_a_scenario_without_the_guards_warns_instead_of_0_undetected(cli, tmp_path):
    res = cli("faults", str(_tiny(tmp_path)))
    assert res.exit_code == 0, res.stderr
    warning = [ln for ln in res.stderr.splitlines() if ln.startswith("warning:")]
    assert warning and "ft_dropout" in warning[0] and "sensor_health" in warning[0]
    assert "estop" not in warning[0]
    assert "no guard of the scenario can see" in res.stdout
    header = next(ln for ln in res.stdout.splitlines() if ln.startswith("fault"))
    for column in ("detect [s]", "stop time [s]", "stop distance [mm]"):  # figures with units
        assert column in header, header
    rows = json.loads(cli("faults", str(_tiny(tmp_path)), "--json").stdout)
    blind = {r["fault"].split("@")[0]: r["blind"] for r in rows}
    assert blind["ft_dropout"] is True and blind["estop"] is False


SKILL = """\
from typing import ClassVar

from orchestrator.skills import Skill, SkillParams


class WaitKey(Skill):
    \"\"\"Waits until the blackboard's [key] is set, [bold]now[/bold].\"\"\"

    name: ClassVar[str] = "wait_key_own"
    Params = SkillParams
    outcomes: ClassVar[tuple[str, ...]] = ("done",)

    def step(self, ctx):
        return "done"
"""


def test_list_prints_brackets_of_ones_own_skill_as_written(cli_process, tmp_path):
    (tmp_path / "mine").mkdir()
    (tmp_path / "mine" / "wait_key.py").write_text(SKILL)
    res = cli_process("list", "skills", "--skills", str(tmp_path / "mine"))
    assert res.exit_code == 0, res.stderr
    line = next(ln for ln in res.stdout.splitlines() if "wait_key_own" in ln)
    assert "blackboard's [key] is set, [bold]now[/bold]." in line  # not eaten as markup


def test_the_run_table_header_keeps_its_unit(cli):
    res = cli("run", "pick_place", "--set", "physics.time_limit_s=0.3")
    header = next(ln for ln in res.stdout.splitlines() if "from" in ln and "trigger" in ln)
    assert header.lstrip().startswith("t [s]"), header
