"""A snapshot resumes from its data: the run is built for the recipe and seed, the recorded
state is put into it (no step re-simulated) and it ends as the uninterrupted run, bit for bit.
A user's own skill that holds an object of its own declares `snapshot_state` and
`restore_state`; a user's own success check resumes with its default; the replay check
(`verify`) stays available and agrees."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from orchestrator.engine.runner import drive, new_run
from orchestrator.engine.snapshot.identity import comparable
from orchestrator.engine.snapshot.run_snapshot import load_run, write_run
from orchestrator.engine.snapshot.signing import KEY_ENV
from orchestrator.engine.snapshot.stops import Stop, run_to
from orchestrator.language.load import load_scenario

SKILL = '''\
from typing import ClassVar

from orchestrator.skills import Skill, SkillParams
from orchestrator.skills.plain_state import plain_state, restore_plain


class _Seen:
    """An object of the skill's own: the times it stepped at."""

    def __init__(self):
        self.times = []


class CountParams(SkillParams):
    ticks: int = 40


class CountTicks(Skill):
    """Steps `ticks` control ticks, noting the time of each."""

    name: ClassVar[str] = "count_ticks_restore"
    Params = CountParams
    outcomes: ClassVar[tuple[str, ...]] = ("done",)

    def start(self, ctx):
        self.seen = _Seen()
        self.t0 = ctx.t

    def step(self, ctx):
        self.seen.times.append(round(ctx.t - self.t0, 6))
        if len(self.seen.times) < self.params.ticks:
            return None
        ctx.metrics["counted_ticks"] = len(self.seen.times)
        ctx.metrics["counted_span_s"] = self.seen.times[-1] - self.seen.times[0]
        return "done"

    def snapshot_state(self):
        return {**plain_state(self), "times": list(self.seen.times)}

    def restore_state(self, data):
        data = dict(data)
        times = data.pop("times")
        restore_plain(self, data)
        self.seen = _Seen()
        self.seen.times = list(times)
'''

CHECK = '''\
from typing import ClassVar

from orchestrator.success import CheckParams, SuccessCheck, Verdict


class CountedParams(CheckParams):
    at_least: int = 1


class Counted(SuccessCheck):
    """The skill counted at least `at_least` ticks."""

    kind: ClassVar[str] = "counted_restore"
    Params = CountedParams

    def evaluate(self, ctx):
        n = ctx.metrics.get("counted_ticks", 0)
        return Verdict(n >= self.params.at_least, f"{n} ticks counted")
'''

MACHINE = """\
name: counting
initial: COUNT
guards: [joint_limits]
states:
  COUNT:
    skill: count_ticks_restore
    with: {ticks: 40}
    transitions: {done: DONE}
  DONE: {final: succeeded}
"""

SCENARIO = """\
name: counting_cell
machine: counting.yaml
skills: [mine]
scene:
  objects:
    - {name: cube, size: [0.05, 0.05, 0.05], xy: [0.5, 0.0]}
success:
  counted: {kind: counted_restore, at_least: 40}
"""

PROBE = """\
import json, sys, tempfile
from pathlib import Path
from orchestrator.engine.runner import drive, new_run
from orchestrator.engine.snapshot import local_skill_files
from orchestrator.engine.snapshot.identity import comparable
from orchestrator.engine.snapshot.run_snapshot import load_run, write_run
from orchestrator.engine.snapshot.stops import Stop, run_to
from orchestrator.language.load import load_scenario

loaded = load_scenario(sys.argv[1])
full = comparable(drive(new_run(loaded, 3)))
run = new_run(loaded, 3)
stop = Stop(20, False, "inside COUNT", "test")
assert run_to(run, stop)
recorded = run.executor.region.activity.skill.snapshot_state()
path = Path(tempfile.mkdtemp()) / "count.snap"
write_run(path, run, stop.header(), local_skill_files())
del run
snap = load_run(path, restore=True)
assert snap.how == "restored", snap.how
skill = snap.run.executor.region.activity.skill
times_back = skill is not None and skill.seen.times == recorded["times"]
print(json.dumps({
    "full": full,
    "resumed": comparable(drive(snap.run)),
    "times_back": times_back,
    "ticks_at_break": len(recorded["times"]),
}))
"""


@pytest.fixture()
def cell(tmp_path: Path) -> Path:
    (tmp_path / "mine").mkdir()
    (tmp_path / "mine" / "count_ticks.py").write_text(SKILL)
    (tmp_path / "mine" / "counted.py").write_text(CHECK)
    (tmp_path / "counting.yaml").write_text(MACHINE)
    (tmp_path / "counting_cell.yaml").write_text(SCENARIO)
    return tmp_path / "counting_cell.yaml"


def test_a_users_skill_and_check_resume_from_their_data(cell, tmp_path):
    # in a process of its own: the folder's skill and check are registered once per process
    env = {**os.environ, "XDG_CONFIG_HOME": str(tmp_path / "config")}
    env.pop(KEY_ENV, None)
    proc = subprocess.run([sys.executable, "-c", PROBE, str(cell)], env=env,
                          capture_output=True, text=True, timeout=300, check=False)  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    out = json.loads(proc.stdout.splitlines()[-1])
    assert out["ticks_at_break"] > 0  # broken while the skill was running
    assert out["times_back"]  # its own object made again by its restore_state
    assert out["resumed"]["success"]["counted"] is True  # the user's check judged it
    assert out["resumed"] == out["full"]


@pytest.mark.parametrize("tick", [180, 223])
def test_restoring_is_the_replay(tick, tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CONFIG_HOME", str(tmp_path / "config"))
    monkeypatch.delenv(KEY_ENV, raising=False)
    loaded = load_scenario("pick_place")
    full = comparable(drive(new_run(loaded, 0)))
    run = new_run(loaded, 0)
    stop = Stop(tick, False, f"control tick {tick}", "test")
    assert run_to(run, stop)
    path = tmp_path / "p.snap"
    write_run(path, run, stop.header(), [])
    restored, replayed = load_run(path, restore=True), load_run(path)
    assert (restored.how, replayed.how) == ("restored", "verified")
    assert restored.run.ctx.tick == replayed.run.ctx.tick == tick
    assert comparable(drive(restored.run)) == comparable(drive(replayed.run)) == full
