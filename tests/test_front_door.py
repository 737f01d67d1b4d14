"""One front door (engine/prepare.py): `run`, `batch`, `faults`, `serve` and time travel prepare
a run the same way — the same refusals with the same messages, one world compiled per run —
and every re-run command a batch prints reproduces its episode."""

from __future__ import annotations

import json
import shlex
import shutil
from collections import Counter
from pathlib import Path

import mujoco
import pytest

from .conftest import REPO

OUTSIDE = "place_at=[1.2, 0.2, 0.3]"
"""A place 25 cm beyond the workspace box's x limit: `run` refuses it."""
ABORT = "guards.workspace.max=[0.95, 0.1, 1.2]"
"""The box cut short on the pad's side: the carried cube leaves it, the run is aborted (a floor
above the cube is refused by `grasp_pose` before the hand goes down)."""


@pytest.mark.parametrize(
    "value",
    [
        OUTSIDE,
        "blackboard.place_at=[1.2, 0.2, 0.3]",  # the same key by its scenario path
        "hover=[0, 0, 5]",  # an offset, added to where the cube is
    ],
)
def test_batch_and_faults_refuse_what_run_refuses_with_the_same_message(cli, tmp_path, value):
    run = cli("run", "pick_place", "--set", value)
    assert run.exit_code == 2 and run.exception is None
    assert "<--set>: goal rejected:" in run.stderr and "nothing was simulated" in run.stderr
    out = tmp_path / "b"
    batch = cli("batch", "pick_place", "-n", "2", "--out", str(out), "--set", value)
    assert (batch.exit_code, batch.stderr, batch.stdout) == (2, run.stderr, "")
    assert not out.exists()  # refused before any episode ran
    faults = cli("faults", "pick_place", "--set", value)
    assert (faults.exit_code, faults.stderr, faults.stdout) == (2, run.stderr, "")


@pytest.fixture
def compiles(monkeypatch):
    """Counts MuJoCo compiles by model name (a world's model is named after its scenario)."""
    counted: Counter[str] = Counter()
    real = mujoco.MjSpec.compile

    def compile_(spec, *args, **kwargs):
        counted[spec.modelname] += 1
        return real(spec, *args, **kwargs)

    monkeypatch.setattr(mujoco.MjSpec, "compile", compile_)
    return counted


def test_one_run_with_set_compiles_the_world_once(cli, compiles):
    res = cli("run", "pick_place", "--seed", "2", "--set", "place_at=[0.5, 0.1, 0.3]", "--json")
    assert res.exit_code == 0, res.stderr
    assert res.json["outcome"] == "succeeded"
    assert compiles["pick_place"] == 1  # validation, goal check and run: one world
    compiles.clear()
    res = cli("run", "pick_place", "--set", OUTSIDE)
    assert res.exit_code == 2 and compiles["pick_place"] == 1


def test_serve_and_each_batch_episode_compile_their_world_once(compiles, tmp_path):
    from orchestrator.batch.episode import run_task
    from orchestrator.batch.task import EpisodeTask
    from orchestrator.live.session import Session

    Session("pick_place", "door", seed=4)
    assert compiles["pick_place"] == 1
    compiles.clear()
    short = ("physics.time_limit_s=0.3",)  # the episodes end early: the count is the point
    for seed in (3, 4):
        line = run_task(EpisodeTask("pick_place", short, seed, "none", str(tmp_path), 60.0))
        assert line["outcome"] == "failed", line
    assert compiles["pick_place"] == 2


def _rerun(cli_process, stdout: str):
    """Run the command a batch printed (`re-run one: ...`) with --json, in a process of its
    own as a user would (not beside what other tests imported into this one)."""
    printed = [ln for ln in stdout.splitlines() if ln.startswith("re-run one:")]
    assert len(printed) == 1, stdout
    args = shlex.split(printed[0].removeprefix("re-run one:"))
    assert args[:2] == ["orchestrator", "run"], args
    return cli_process(*args[1:], "--json")


def _only_line(out: Path) -> dict:
    (line,) = [json.loads(t) for t in (out / "results.jsonl").read_text().splitlines()]
    return line


def test_the_rerun_command_of_an_aborted_episode_reproduces_it(cli, cli_process, tmp_path):
    """A scenario whose machine lives outside its folder: the batch needs --allow-path, and so
    does the command it prints."""
    lib = tmp_path / "lib"
    lib.mkdir()
    for name in ("pick_place.yaml", "grasp.yaml"):
        shutil.copy(REPO / "machines" / name, lib / name)
    cell = tmp_path / "cell"
    cell.mkdir()
    text = (REPO / "scenarios" / "pick_place.yaml").read_text()
    text = text.replace("machine: pick_place\n", f"machine: {lib / 'pick_place.yaml'}\n")
    (cell / "cell.yaml").write_text(text)
    out = tmp_path / "b"
    res = cli("batch", str(cell / "cell.yaml"), "-n", "1", "--seed-base", "2", "--out", str(out),
              "--record", "none", "--set", ABORT, "--allow-path", str(lib))  # fmt: skip
    assert res.exit_code == 0, res.stderr
    episode = _only_line(out)
    assert episode["outcome"] == "aborted" and episode["seed"] == 2
    again = _rerun(cli_process, res.stdout)
    assert again.exit_code == 3, again.stderr
    rerun = again.json
    for key in ("wall_time", "worker"):  # how it ran, not what happened
        rerun.pop(key, None)
        episode.pop(key, None)
    assert rerun == episode


@pytest.mark.slow  # a batch, a snapshot and its resume (~5 s)
def test_the_rerun_command_of_a_failed_episode_resumes_its_snapshot_and_reproduces_it(
    cli, cli_process, tmp_path
):
    out = tmp_path / "b"
    res = cli("batch", "pick_place", "-n", "1", "--seed-base", "1", "--out", str(out),
              "--record", "none", "--snapshot-on-failure", "--set",
              "physics.time_limit_s=2.5")  # fmt: skip
    assert res.exit_code == 0, res.stderr
    episode = _only_line(out)
    assert episode["outcome"] == "failed" and episode.get("snapshot"), episode
    again = _rerun(cli_process, res.stdout)
    assert again.exit_code == 1, again.stderr
    assert "--from" in res.stdout  # the printed command resumes the snapshot
    for key in ("outcome", "final_state", "metrics"):
        assert again.json[key] == episode[key], key


def test_a_resumed_run_checks_its_new_goals_from_where_the_arm_is(cli, tmp_path):
    snap = tmp_path / "at_transport.snap"
    res = cli("run", "pick_place", "--break", "TRANSPORT", "--snapshot", str(snap))
    assert res.exit_code == 6, res.stderr
    res = cli("run", "--from", str(snap), "--set", OUTSIDE)
    assert res.exit_code == 2 and res.exception is None
    assert "<--set>: goal rejected: place_at = [1.2, 0.2, 0.3]" in res.stderr
    assert "nothing was resumed" in res.stderr


def test_an_episode_whose_goal_its_own_objects_refuse_is_refused_as_run_refuses_it(
    cli, cli_process, tmp_path
):
    """A position hint must be near the object: the cube is drawn within it for seed 3, not
    for seed 4. The batch starts (seed 3 is fine), the episode of seed 4 is refused in its
    worker with `run`'s message, and its printed re-run command gives that refusal."""
    hint = "pick_at=[0.5, -0.12, 0.225]"
    out = tmp_path / "b"
    res = cli("batch", "pick_place", "-n", "2", "--seed-base", "3", "--out", str(out),
              "--record", "none", "--set", hint)  # fmt: skip
    assert res.exit_code == 1, res.stderr  # an episode did not run
    lines = {ln["seed"]: ln for ln in map(json.loads, (out / "results.jsonl").open())}
    assert lines[3]["outcome"] == "succeeded"
    error = lines[4]["error"]
    assert lines[4]["outcome"] == "error" and error["traceback"] is None
    again = _rerun(cli_process, res.stdout)
    assert again.exit_code == 2 and again.stdout == ""
    assert again.stderr.splitlines()[0] == error["message"]
    assert error["message"].startswith("<--set>: goal rejected: pick_at = [0.5, -0.12, 0.225]")
