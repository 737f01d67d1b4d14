"""Hostile and broken inputs (issue 10, part 3): every one is answered with exit 2 and
messages naming a real `file:line:col` — never a traceback, never a hang. The inputs come from
`tests/hostile.py` (one generator per class that once broke the tool) and from hypothesis
mutations of the bundled files; `bench/fuzz_campaign.py` runs the large campaign and measures
answer times against the 2 s target."""

from __future__ import annotations

import os
import re
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st
from yaml.scanner import ScannerError

from orchestrator.batch.exceptions import BatchError
from orchestrator.batch.lock import LOCK, BatchLock
from orchestrator.engine.runner import WallTimeExceeded, run_episode
from orchestrator.language import yamlio
from orchestrator.language.load import load_scenario

from .hostile import (
    BUNDLED,
    FRAGMENTS,
    Hostile,
    every_hostile,
    final_start_retry,
    splice,
    write_bundled,
)

REPO = Path(__file__).resolve().parent.parent
POSITION = re.compile(r"^(?P<file>.+?):(?P<line>\d+):(?P<col>\d+): \S")
SUMMARY = re.compile(r"^\d+ errors?; (nothing was simulated|the run was stopped)\.$")
HANG_S = 15.0
"""A bound on the CPU seconds of this process (`time.process_time`: the CLI runs in it) that
only a hang or a super-linear blow-up crosses (the campaign found 116 s and 150 s+ answers);
CPU, not wall time: beside busy processes the 9000 chained states took 18.5 s of wall time
for ~1.5 s of CPU. The 2 s target itself is measured by `bench/fuzz_campaign.py` on one run,
not asserted here."""

VALID = {"9000 chained states", final_start_retry().name}
"""Hostile-looking inputs that are valid: they must pass, in time."""


def _diagnostics(stderr: str, file: Path) -> list[tuple[int, int, str]]:
    """(line, col, text) of every message; asserts each has the form `file:line:col: ...`."""
    lines = [ln for ln in stderr.splitlines() if ln.strip()]
    assert lines and SUMMARY.match(lines[-1]), f"no summary line in {stderr!r}"
    found = []
    for ln in lines[:-1]:
        m = POSITION.match(ln)
        assert m, f"not `file:line:col: message`: {ln!r}"
        assert Path(m["file"]).parent.resolve() == file.parent.resolve() or m["file"] == str(file)
        found.append((int(m["line"]), int(m["col"]), ln))
    return found


@pytest.mark.parametrize("hostile", every_hostile(), ids=lambda h: h.name)
def test_hostile_input_is_answered_fast_at_its_position(cli, tmp_path, hostile: Hostile):
    entry = hostile.write(tmp_path)
    t0 = time.process_time()
    res = cli("validate", str(entry))
    took = time.process_time() - t0
    assert res.exception is None, f"{hostile.name}: {res.exception!r}"
    assert "Traceback" not in res.stderr + res.stdout
    assert took < HANG_S, f"{hostile.name}: answered in {took:.1f} s"
    if hostile.name in VALID:
        assert res.exit_code == 0, res.stderr
        return
    assert res.exit_code == 2, f"{hostile.name}: exit {res.exit_code}\n{res.stdout}"
    diags = _diagnostics(res.stderr, entry)
    line, col, first = diags[0]
    assert line >= 1 and col >= 1, first
    if hostile.line:
        assert line == hostile.line, first
    assert hostile.fragment in res.stderr
    # what an include names is never echoed: a message quotes at most ~80 characters of it
    assert "hunter2" not in res.stderr and "secret-hash" not in res.stderr
    assert all(len(text) < 600 for _, _, text in diags), max(diags, key=lambda d: len(d[2]))


def test_user_text_reaches_the_terminal_verbatim_not_as_markup_or_emoji(cli, tmp_path):
    # an error on line 100 once printed as `file💯7`; markup in a value was interpreted
    (tmp_path / "m.yaml").write_text(
        "name: m\ninitial: A\nstates:\n  A: {skill: hold, transitions: {held: B}}\n"
        + "# pad\n" * 95
        + "  B: {final: ok, colour: '[bold red]:smile:[/]'}\n"
    )
    res = cli("validate", str(tmp_path / "m.yaml"))
    assert res.exit_code == 2
    assert f"{tmp_path / 'm.yaml'}:100:" in res.stderr
    assert "'[bold red]:smile:[/]'" in res.stderr or "colour" in res.stderr
    assert "💯" not in res.stderr and "😄" not in res.stderr


# --- mutations: the bundled files with hostile fragments spliced in ---------------------------


@st.composite
def hostile_mutations(draw) -> tuple[str, bytes]:
    """(which file, its bytes): a hostile fragment spliced into a line (as a value, a key, a
    new line, or raw), or raw bytes (non-UTF-8, control characters) inserted anywhere."""
    which = draw(st.sampled_from(sorted(BUNDLED)))
    lines = BUNDLED[which].splitlines(keepends=True)
    i = draw(st.integers(0, len(lines) - 1))
    how = draw(st.sampled_from(["value", "key", "line", "raw", "bytes"]))
    if how == "bytes":
        text = BUNDLED[which].encode()
        at = draw(st.integers(0, len(text)))
        return which, text[:at] + draw(st.binary(min_size=1, max_size=8)) + text[at:]
    frag = draw(st.sampled_from(FRAGMENTS))
    return which, splice(lines, i, how, frag, draw(st.integers(0, len(lines[i]))))


def _check_mutation(root: Path, cli, which: str, data: bytes) -> None:
    entry = write_bundled(root, which, data)
    t0 = time.process_time()
    res = cli("validate", str(entry))
    assert time.process_time() - t0 < HANG_S
    assert res.exception is None, repr(res.exception)
    assert "Traceback" not in res.stderr
    assert res.exit_code in (0, 2), res.stderr
    event(f"exit {res.exit_code}")
    if res.exit_code == 2:
        for line, col, text in _diagnostics(res.stderr, entry):
            assert line >= 1 and col >= 1, text


MUTATIONS = settings(
    max_examples=120,
    deadline=None,
    derandomize=True,
    database=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)


@settings(MUTATIONS, max_examples=60)  # the slow suite tries 2500 more, drawn afresh each run
@given(mutation=hostile_mutations())
def test_hostile_mutations_exit_0_or_2_with_real_positions(tmp_path_factory, cli, mutation):
    _check_mutation(tmp_path_factory.mktemp("hostile"), cli, *mutation)


@pytest.mark.slow
@settings(MUTATIONS, max_examples=2500, derandomize=False)
@given(mutation=hostile_mutations())
def test_many_hostile_mutations_exit_0_or_2_with_real_positions(tmp_path_factory, cli, mutation):
    _check_mutation(tmp_path_factory.mktemp("hostile"), cli, *mutation)


# --- run, batch: invocations ------------------------------------------------------------------


@pytest.mark.parametrize(
    ("args", "fragment"),
    [
        (["--seed", "-1"], "--seed"),
        (["--seed", "1" * 30], "--seed"),
        (["--max-wall-s", "0"], "--max-wall-s"),
        (["--max-wall-s", "nan"], "--max-wall-s"),
        (["--max-wall-s", "inf"], "finite"),
        (["--set", "physics.timestep_s=" + "1" * 5000], "too long"),
        (["--set", "physics.timestep_s=!!python/object/apply:os.system [ls]"], "unknown YAML tag"),
        (["--set", "guards=&a [*a]"], "recursive alias"),
        (["--allow-path", "/nonexistent-issue10"], "does not exist"),
        (["--rrd", "/proc/issue10/x.rrd"], "the folder /proc/issue10 does not exist"),
        (["--set", "physics.control_hz=1e-6"], "physics.control_hz"),
        (["--set", "physics.timestep_s=1e-300"], "physics.timestep_s"),
        (["--set", "physics.time_limit_s=1e300"], "physics.time_limit_s"),
        (["--set", "machine=" + "a" * 5000], "machine"),
        (["--set", "machine=../../etc/passwd"], "machine"),
        # overflow and NaN in a fault, an event or a goal: named with the option, no traceback
        (["--fault", "perception_offset:offset_m=[1e308,0,0]@0"],
         "faults[0].offset_m[0]: Input should be less than or equal to 10, got '1e308' (from "
         "--fault perception_offset:offset_m=[1e308,0,0]@0)"),
        (["--fault", "push:object=cube,force_n=[1.0e+308,0,0]@0.5"],
         "less than or equal to 1000, got 1e+308 (from --fault push"),
        (["--fault", "ft_bias:force_n=[0,0,.nan]@0"], "finite number, got nan (from --fault"),
        (["--fault", "perception_miss:count=" + "1" * 5000 + "@0"],
         "<--fault>: perception_miss:count=111"),
        (["--fault", "push:force_n=" + "[" * 3000 + "]" * 3000 + "@0"],
         "nested deeper than 64 levels"),
        (["--fault", "estop@1e400"], "<--fault>: faults[0].at: Input should be a finite number"),
        (["--event", "1e400:estop"], "<--event>: 1e400:estop: time '1e400' must be a finite"),
        (["--event", "nan:estop"], "<--event>: nan:estop"),
        (["--set", "place_at=[1.0e+308,0,0.3]"], "<--set>: goal rejected: place_at"),
        (["--set", "place_at=NaN"], "<--set>: blackboard.place_at: 'NaN' is not finite"),
    ],
)  # fmt: skip
def test_bad_run_invocations_exit_2_before_simulating(cli, args, fragment):
    t0 = time.process_time()
    res = cli("run", "pick_place", *args)
    assert res.exception is None, repr(res.exception)
    assert res.exit_code == 2, res.stdout
    assert fragment in res.stderr + res.stdout
    assert "Traceback" not in res.stderr
    assert time.process_time() - t0 < HANG_S  # nothing was simulated


class _CappedParser(yaml.SafeLoader):
    """A YAML parser with its own nesting cap (100 flow levels), met while its scanner reads
    ahead, as some PyYAML and libyaml builds have: the cap must not be what the user sees."""

    def fetch_flow_collection_start(self, TokenClass):  # noqa: N803 - PyYAML's name
        if self.flow_level >= 100:
            mark = self.get_mark()
            raise ScannerError("while scanning", mark, "exceeded max depth of 100", mark)
        super().fetch_flow_collection_start(TokenClass)


@pytest.mark.parametrize("opening", ["[", "{a: "])
def test_deep_flow_nesting_is_refused_by_our_limit_before_a_parsers_own_cap(
    cli, monkeypatch, opening
):
    """Ours is the first nesting check whatever PyYAML's build does: a run of 3000 openings on
    one line (the scanner reads ahead past 100 before any event) still gets the max_depth
    message, at the 65th level, naming the limit."""
    monkeypatch.setattr(yamlio, "_LOADER", _CappedParser)
    closing = "]" if opening == "[" else "}"
    value = opening * 3000 + "1" + closing * 3000
    res = cli("run", "pick_place", "--fault", f"push:force_n={value}@0")
    assert res.exception is None, repr(res.exception)
    assert res.exit_code == 2, res.stdout
    out = res.stderr + res.stdout
    assert "nested deeper than 64 levels (limit max_depth" in out, out[-400:]
    assert "exceeded max depth" not in out


def test_rrd_pointing_at_a_directory_is_refused_before_the_episode_runs(cli, tmp_path):
    res = cli("run", "pick_place", "--rrd", str(tmp_path))
    assert res.exit_code == 2
    assert "is a directory" in res.stderr and "run.rrd" in res.stderr
    assert "succeeded" not in res.stdout  # refused before, not after, the episode


def test_rrd_into_a_missing_folder_is_refused_and_the_folder_never_made(cli, tmp_path):
    target = tmp_path / "no" / "such" / "x.rrd"
    res = cli("run", "pick_place", "--rrd", str(target))
    assert res.exit_code == 2
    assert f"--rrd {target}: the folder {target.parent} does not exist" in res.stderr
    assert not (tmp_path / "no").exists()


# --- skills: a scenario's Python stays in its tree, and only runs when the scenario runs ------

MARKER_SKILL = """import pathlib
from typing import ClassVar
from orchestrator.skills import Skill, SkillParams

pathlib.Path({marker!r}).write_text("this module ran")


class Mark(Skill):
    \"\"\"Finish at once.\"\"\"

    name: ClassVar[str] = {name!r}
    Params: ClassVar[type[SkillParams]] = SkillParams
    outcomes: ClassVar[tuple[str, ...]] = ("done",)

    def step(self, ctx):
        return "done"
"""


def _marker_cell(root: Path, entry: str, skill: str = "mark") -> tuple[Path, Path]:
    """A scenario in root/proj/deep naming `entry` in its `skills:`, a machine that runs the
    skill `skill`, and a skill module root/outside/mark.py that writes a marker when imported.
    Returns (the scenario, the marker)."""
    marker = root / "MARKER"
    (root / "outside").mkdir()
    (root / "outside" / "mark.py").write_text(MARKER_SKILL.format(marker=str(marker), name=skill))
    deep = root / "proj" / "deep"
    deep.mkdir(parents=True)
    (deep / "m.yaml").write_text(
        f"name: m\ninitial: A\nstates:\n  A: {{skill: {skill}, transitions: {{done: B}}}}\n"
        "  B: {final: succeeded}\n"
    )
    (deep / "s.yaml").write_text(f"name: s\nmachine: m.yaml\nskills:\n  - {entry}\n")
    (deep / "link").symlink_to(root / "outside")
    return deep / "s.yaml", marker


@pytest.mark.parametrize("how", ["absolute", "dotdot", "symlink"])
def test_skills_outside_the_tree_are_refused_and_never_executed(cli, tmp_path, how):
    entry = {"absolute": str(tmp_path / "outside"), "dotdot": "../../outside", "symlink": "link"}
    scenario, marker = _marker_cell(tmp_path, entry[how])
    for command in (["validate"], ["run"], ["graph"], ["show", "scenario"]):
        res = cli(*command, str(scenario))
        assert res.exception is None, repr(res.exception)
        assert res.exit_code == 2, (command, res.stdout)
        assert f"{scenario}:4:5: skills[0]: " in res.stderr
        assert "outside" in res.stderr and "--allow-path DIR" in res.stderr, res.stderr
        assert not marker.exists(), f"{command} executed the module a file named"


def test_validate_imports_no_skill_a_file_names_even_inside_its_tree(cli, tmp_path):
    scenario, marker = _marker_cell(tmp_path, "mine", skill="mark_intree")
    (scenario.parent / "mine").mkdir()
    (tmp_path / "outside" / "mark.py").rename(scenario.parent / "mine" / "mark.py")
    res = cli("validate", str(scenario))
    assert res.exit_code == 2
    assert "states.A.skill: unknown skill 'mark_intree'; the scenario's skills: are not " in (
        res.stderr
    )
    assert f"pass --skills {scenario.parent / 'mine'}" in res.stderr
    assert not marker.exists()


def test_skills_the_user_names_or_allows_do_run(cli_process, tmp_path):
    scenario, marker = _marker_cell(tmp_path, "../../outside", skill="mark_allowed")
    res = cli_process("validate", str(scenario), "--skills", str(tmp_path / "outside"))
    assert res.exit_code == 0, res.stderr  # named on the command line: the user's own choice
    assert marker.read_text() == "this module ran"
    marker.unlink()
    res = cli_process("run", str(scenario), "--allow-path", str(tmp_path / "outside"))
    assert res.exit_code == 0, res.stderr  # `run` imports what the tree (widened) holds
    assert marker.exists()


def test_a_module_that_fails_to_import_is_named_by_type_and_line_never_quoted(cli, tmp_path):
    (tmp_path / "s.yaml").write_text("name: s\nmachine: pick_place\nskills: [notes.py]\n")
    (tmp_path / "notes.py").write_text("# my notes\n\nhunter2_SECRET_password\n")
    res = cli("run", str(tmp_path / "s.yaml"))
    assert res.exit_code == 2
    assert f"{tmp_path / 'notes.py'}:3: the skill module fails to import: NameError " in (
        res.stderr
    )
    assert "hunter2" not in res.stderr + res.stdout


def test_set_machine_chooses_the_machine():
    loaded = load_scenario("pick_place", ["machine=surgical"])
    assert loaded.scenario.machine == "surgical"
    assert loaded.machine.name != load_scenario("pick_place").machine.name


def test_batch_seed_base_below_zero_is_one_error(cli, tmp_path):
    res = cli("batch", "pick_place", "-n", "2", "--seed-base", "-5", "--out", str(tmp_path / "b"))
    assert res.exit_code == 2
    assert "--seed-base" in res.stderr + res.stdout
    assert not (tmp_path / "b").exists()


def test_a_nested_machine_that_finishes_at_once_retries_in_a_loop(cli, tmp_path):
    entry = final_start_retry().write(tmp_path)
    res = cli("run", str(entry))
    assert res.exception is None, repr(res.exception)
    assert res.exit_code == 0, res.stderr
    assert "more transitions: --json lists them all" in res.stdout  # 10,001 rows summarized
    assert len(res.stdout.splitlines()) < 80


# --- wall-clock limits ------------------------------------------------------------------------


def test_max_wall_s_stops_the_episode_brings_the_arm_to_rest_and_says_why(pick_place):
    with pytest.raises(WallTimeExceeded) as info:
        run_episode(pick_place, 0, max_wall_s=0.05)
    result = info.value.result
    assert "wall-clock limit of 0.05 s" in str(info.value)
    assert result.metrics["error"] == str(info.value)
    assert result.sim_time < 4.0  # stopped early; pick_place takes ~4.6 s simulated
    assert result.metrics["rest_speed_rad_s"] < 0.05  # the arm was brought to rest


def test_run_max_wall_s_exits_4_with_the_reason(cli):
    res = cli("run", "pick_place", "--max-wall-s", "0.05", "--json")
    assert res.exit_code == 4  # outcome `error`, as a skill that raised (README's table)
    assert "wall-clock limit" in res.stderr
    line = res.json
    assert line["outcome"] == "error" and line["error"]["type"] == "WallTimeExceeded"


def test_batch_records_an_episode_past_its_wall_limit_as_error(cli, tmp_path):
    out = tmp_path / "b"
    res = cli(
        "batch", "pick_place", "-n", "1", "--workers", "1", "--max-wall-s", "0.05",
        "--out", str(out), "--json", "--record", "none",
    )  # fmt: skip
    assert res.exception is None, repr(res.exception)
    lines = (out / "results.jsonl").read_text().splitlines()
    assert len(lines) == 1
    assert '"outcome": "error"' in lines[0] and "WallTimeExceeded" in lines[0]
    assert "wall-clock limit of 0.05 s" in lines[0]


# --- one batch per directory ------------------------------------------------------------------


def test_a_second_batch_on_the_same_directory_exits_2_naming_the_holder(cli, tmp_path):
    out = tmp_path / "b"
    holder = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    try:
        out.mkdir()
        (out / LOCK).write_text(
            f'{{"pid": {holder.pid}, "host": "{socket.gethostname()}", "since": 0}}\n'
        )
        res = cli("batch", "pick_place", "-n", "1", "--out", str(out))
        assert res.exit_code == 2
        assert f"pid {holder.pid}" in res.stderr and "in use by another batch" in res.stderr
        assert not (out / "results.jsonl").exists()
    finally:
        holder.kill()
        holder.wait()


def test_a_lock_left_by_a_dead_batch_is_taken_over_and_released(tmp_path):
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    (tmp_path / LOCK).write_text(
        f'{{"pid": {dead.pid}, "host": "{socket.gethostname()}", "since": 0}}\n'
    )
    with BatchLock(tmp_path):
        assert f'"pid": {os.getpid()}' in (tmp_path / LOCK).read_text()
        with pytest.raises(BatchError, match="in use by another batch"):
            BatchLock(tmp_path).acquire()  # held by a live process (this one)
    assert not (tmp_path / LOCK).exists()


def test_nan_in_a_blackboard_default_or_override_is_refused_before_simulating(cli, tmp_path):
    (tmp_path / "m.yaml").write_text(
        "name: m\ninitial: A\nblackboard:\n  x: [0.1, .nan]\nstates:\n"
        "  A: {skill: hold, with: {duration_s: 0.1}, transitions: {held: B}}\n"
        "  B: {final: succeeded}\n"
    )
    res = cli("validate", str(tmp_path / "m.yaml"))
    assert res.exit_code == 2
    assert f"{tmp_path / 'm.yaml'}:4:3: blackboard.x:" in res.stderr and "NaN" in res.stderr
    res = cli("run", "pick_place", "--set", "place_at=[.nan,0,0]")
    assert res.exit_code == 2
    assert "blackboard.place_at" in res.stderr and "nothing was simulated" in res.stderr


def test_a_goal_near_the_largest_float_is_refused_without_a_numeric_warning(cli):
    # the refusal prints the goal rounded: numpy's rounding scaled 1e308 by 1e4 and warned
    # "overflow encountered in multiply" on the user's terminal beside the message
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        res = cli("run", "pick_place", "--set", "place_at=[1.0e+308,0,0.3]")
    assert res.exit_code == 2 and res.exception is None, res.exception
    assert "goal rejected: place_at = [1e+308, 0.0, 0.3]" in res.stderr


def stuck_run(task) -> dict:
    """A worker's episode function: seed 1 never comes back (as if stuck in one MuJoCo step)."""
    if task.seed == 1:
        time.sleep(3600)
    return {"scenario": "fake", "seed": task.seed, "outcome": "succeeded", "metrics": {}}


@pytest.mark.slow  # waits out a wall limit (~9 s)
def test_a_worker_stuck_past_the_wall_limit_is_killed_and_the_batch_goes_on(tmp_path, monkeypatch):
    from orchestrator.batch import BatchConfig, run_batch
    from orchestrator.batch.backends import local

    monkeypatch.setattr(local, "_HARD_GRACE_S", 8.0)  # kept by the parent; covers imports
    config = BatchConfig("pick_place", 3, tmp_path / "b", record="none", max_wall_s=0.2)
    t0 = time.perf_counter()
    summary = run_batch(config, backend=local.LocalBackend(2, run_fn=stuck_run))
    assert time.perf_counter() - t0 < 60  # not the hour the episode would have taken
    lines = (tmp_path / "b" / "results.jsonl").read_text().splitlines()
    assert len(lines) == 3
    stuck = next(ln for ln in lines if '"seed": 1' in ln)
    assert "WallTimeExceeded" in stuck and "its worker was killed" in stuck
    assert (summary.succeeded, summary.errors) == (2, 1)
