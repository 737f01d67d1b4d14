"""A skill whose own code raises: the run ends `error` (exit 4) with one line naming the skill's
file:line and the exception, the arm brought to rest by the controlled stop and held —
measured on MuJoCo's state every physics step — and the traceback only with `--debug`.
A batch counts such an episode under `errors`."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from orchestrator.batch.episode import run_task
from orchestrator.batch.summary import summarize
from orchestrator.batch.task import EpisodeTask
from orchestrator.engine.result import EXIT_CODES
from orchestrator.engine.runner import run_episode
from orchestrator.language.load import load_scenario

SKILL = '''\
from typing import ClassVar

from pydantic import Field, PositiveFloat

from orchestrator.skills import Skill, SkillParams


class SwingParams(SkillParams):
    after_s: PositiveFloat = Field(default=0.3, description="Raise after this long [s].")
    raise_in: str = Field(default="step", description="start, step or stop.")


class Swing(Skill):
    """Turn joint 1 at 0.8 rad/s; raise in the method `raise_in` names."""

    name: ClassVar[str] = "swing"
    Params: ClassVar[type[SkillParams]] = SwingParams
    outcomes: ClassVar[tuple[str, ...]] = ("done",)

    def start(self, ctx):
        self.t0 = ctx.clock
        self.q = ctx.q.copy()
        if self.params.raise_in == "start":
            raise KeyError("no such thing")  # START

    def step(self, ctx):
        self.q[0] += 0.8 * ctx.dt_control
        ctx.controller.set_joint_target(self.q)
        if ctx.clock - self.t0 >= self.params.after_s:
            if self.params.raise_in == "step":
                return str(1 / 0)  # STEP
            return "done"
        return None

    def stop(self, ctx):
        if self.params.raise_in == "stop":
            raise RuntimeError("cannot stop")  # STOP
        super().stop(ctx)
'''

MACHINE = """\
name: swing_flow
initial: SWING
states:
  SWING:
    skill: swing
    with: {{raise_in: {where}}}
    transitions: {{done: DONE}}
  DONE: {{final: succeeded}}
"""


@pytest.fixture(scope="module")
def folder(tmp_path_factory) -> Path:
    """A folder with the skill (registered once per process: its name is unique) and one
    scenario per method that raises: `cell_step.yaml`, `cell_start.yaml`, `cell_stop.yaml`."""
    root = tmp_path_factory.mktemp("fault")
    (root / "mine").mkdir()
    (root / "mine" / "swing.py").write_text(SKILL)
    for where in ("step", "start", "stop"):
        (root / f"m_{where}.yaml").write_text(MACHINE.format(where=where))
        (root / f"cell_{where}.yaml").write_text(
            f"name: cell\nmachine: m_{where}.yaml\nskills: [mine]\n"
            "guards: {workspace: {min: [0.05, -0.6, 0.15], max: [0.95, 0.6, 1.2]}}\n"
        )
    return root


def _line_of(marker: str) -> int:
    return next(i for i, text in enumerate(SKILL.splitlines(), 1) if f"# {marker}" in text)


@pytest.mark.parametrize(
    ("where", "marker"), [("step", "STEP"), ("start", "START"), ("stop", "STOP")]
)
def test_a_raising_skill_ends_the_run_error_in_one_line_with_exit_4(cli, folder, where, marker):
    res = cli("run", str(folder / f"cell_{where}.yaml"))
    assert res.exit_code == 4 == EXIT_CODES["error"], res.stderr
    assert res.exception is None and "Traceback" not in res.stderr
    errors = [ln for ln in res.stderr.splitlines() if ln.startswith("error: ")]
    assert len(errors) == 1, res.stderr
    where_line = f"{folder / 'mine' / 'swing.py'}:{_line_of(marker)}"
    assert (
        "error: skill 'swing' raised " in errors[0] and f"({where_line}, in {where};" in errors[0]
    )
    assert (
        "the arm was brought to rest and held (exit 4; --debug prints the traceback)" in errors[0]
    )
    assert "cell seed 0: error in SWING" in res.stdout
    debug = cli("run", str(folder / f"cell_{where}.yaml"), "--debug")
    assert debug.exit_code == 4 and "Traceback (most recent call last)" in debug.stderr
    assert f"# {marker}" in debug.stderr  # the skill's own line is in it


def test_the_error_result_names_the_exception_and_the_measured_stop(cli, folder):
    res = cli("run", str(folder / "cell_step.yaml"), "--json")
    assert res.exit_code == 4
    result = res.json
    assert result["outcome"] == "error" and result["final_state"] == "SWING"
    # every outcome but `succeeded` says why, naming the state and the cause (docs/invariants.md)
    reason = result["reason"]
    assert (reason["kind"], reason["state"]) == ("skill_error", "SWING")
    assert "swing" in reason["message"] and "ZeroDivisionError" in reason["message"]
    error = result["error"]
    assert (error["skill"], error["method"], error["type"]) == (
        "swing",
        "step",
        "ZeroDivisionError",
    )
    assert error["message"] == "division by zero" and error["t"] == pytest.approx(0.3, abs=0.011)
    assert "1 / 0" in error["traceback"]
    m = result["metrics"]
    assert m["cycle_time"] is None
    assert 0.0 < m["stop_time_s"] < 0.5 and 0.0 < m["stop_distance_mm"] < 50.0
    assert m["rest_speed_rad_s"] < 0.005


class _ArmSpeed:
    """Every physics step: simulated time and the fastest arm joint, from MuJoCo's state."""

    def __init__(self) -> None:
        self.samples: list[tuple[float, float]] = []

    def on_start(self, ctx, executor) -> None:
        self.dofs = ctx.world.arm_dof

    def on_tick(self, ctx, executor) -> None: ...

    def on_end(self, ctx, executor, result) -> None: ...

    def on_step(self, ctx) -> None:
        speed = float(np.max(np.abs(ctx.data.qvel[self.dofs])))
        self.samples.append((float(ctx.data.time), speed))


def test_the_arm_is_stopped_and_held_as_measured_on_it(folder):
    loaded = load_scenario(str(folder / "cell_step.yaml"))
    arm = _ArmSpeed()
    result = run_episode(loaded, 0, [arm])
    assert result.outcome == "error" and result.exit_code == 4
    t_raise = result.error["t"]
    moving = max(v for t, v in arm.samples if t <= t_raise)
    assert moving > 0.5  # joint 1 was turning at 0.8 rad/s when the skill raised
    stopped = t_raise + result.metrics["stop_time_s"]
    rest = loaded.scenario.physics.safe_stop.rest_speed_rad_s
    after = [v for t, v in arm.samples if t > stopped + 1e-9]
    # held still from the end of the stop to the end of the run, every physics step
    assert len(after) >= 10 and max(after) < rest
    assert result.metrics["rest_speed_rad_s"] < rest


def test_a_batch_counts_an_episode_whose_skill_raised_under_errors(folder):
    task = EpisodeTask(scenario=str(folder / "cell_step.yaml"), overrides=(), seed=0)
    line = run_task(task)
    assert line["outcome"] == "error"
    assert line["error"]["type"] == "ZeroDivisionError" and "1 / 0" in line["error"]["traceback"]
    summary = summarize(
        [line],
        scenario="cell",
        scenario_ref=str(folder / "cell_step.yaml"),
        overrides=(),
        seed_base=0,
        backend="local",
        workers=1,
        wall_time_s=1.0,
        episodes_run=1,
        results=folder / "results.jsonl",
        rrd_dir=None,
    )
    assert (summary.errors, summary.failed, summary.succeeded) == (1, 0, 0)
    assert math.isclose(summary.success_rate, 0.0)
