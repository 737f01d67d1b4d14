"""The full matrix (slow): every bundled scenario broken at >= 3 points, each resumed from its
snapshot file to the same result as the uninterrupted run; a snapshot resumed in another
process; the resumed recording; a batch's snapshots of its failures.

bench/snapshot_identity.py runs the same matrix and reports sizes and times.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from orchestrator.batch import BatchConfig, run_batch
from orchestrator.engine.runner import drive, new_run, run_episode
from orchestrator.engine.snapshot import local_skill_files, run_to, write_run
from orchestrator.engine.snapshot.identity import MIN_CASES, check, comparable, reference
from orchestrator.engine.snapshot.run_snapshot import load_run
from orchestrator.engine.snapshot.signing import KEY_ENV
from orchestrator.engine.snapshot.stops import Stop
from orchestrator.language.bundled import bundled_names
from orchestrator.language.load import load_scenario
from orchestrator.recording import RerunRecorder
from tests.test_recording import read_rrd

pytestmark = pytest.mark.slow

PARALLEL_PICK = str(Path(__file__).parent / "machines" / "parallel_pick.yaml")
MATRIX = [(name, ()) for name in bundled_names("scenarios")] + [
    ("pick_place", ("perception_miss@0",)),  # PICK retries
    (PARALLEL_PICK, ("perception_miss@0",)),  # a retry, a parallel state, nested machines
]
KINDS = {  # break points the matrix must include: a guard, a retry, a parallel state
    ("surgical_complication", ()): {"guard"},
    ("pick_place", ()): {"nested"},
    ("pick_place", ("perception_miss@0",)): {"retry"},
    (PARALLEL_PICK, ("perception_miss@0",)): {"parallel", "retry", "nested"},
}


@pytest.fixture(autouse=True)
def _own_key(tmp_path_factory, monkeypatch):
    monkeypatch.delenv(KEY_ENV, raising=False)
    monkeypatch.setenv("XDG_CONFIG_HOME", str(tmp_path_factory.getbasetemp() / "config"))


@pytest.mark.parametrize(
    ("name", "faults"), MATRIX, ids=[Path(n).stem + "+".join(("", *f)) for n, f in MATRIX]
)
def test_every_break_point_resumes_to_the_uninterrupted_result(name, faults, tmp_path):
    loaded = load_scenario(name, faults=list(faults))
    result, cases = reference(loaded, 0)
    assert len({c.stop.tick for c in cases}) >= MIN_CASES
    assert KINDS.get((name, faults), set()) <= {c.kind for c in cases}
    expected = comparable(result)
    differ = []
    for case in cases:
        outcome = check(loaded, 0, case, expected, tmp_path)
        if not outcome.identical:
            differ.append(f"{case.stop.reason} (tick {case.stop.tick}): {outcome.difference}")
    assert not differ, differ


@pytest.mark.parametrize("name", ["sorting_conveyor", "mobile_search"])
def test_a_snapshot_resumes_in_another_process(name, tmp_path):
    # another process, another string hash seed: nothing of this process may leak into it
    # (sorting_conveyor reshapes parcels in the model as it runs; mobile_search drives a base)
    loaded = load_scenario(name)
    expected = comparable(run_episode(loaded, 0))
    run = new_run(loaded, 0)
    assert run_to(run, Stop(400, False, "tick 400", "test"))
    path = tmp_path / "mid.snap"
    write_run(path, run, {"reason": "tick 400"}, local_skill_files())
    env = {**os.environ, "PYTHONHASHSEED": "4242"}
    proc = subprocess.run(
        [sys.executable, "-m", "orchestrator.cli", "run", "--from", str(path), "--json"],
        capture_output=True, text=True, check=False, env=env,
    )  # fmt: skip
    got = json.loads(proc.stdout)
    got.pop("wall_time")
    # `comparable` leaves out the invariants: the resumed run measures them from the resume
    assert got.pop("invariants")["from_t"] > 0.0
    assert got == expected


def test_the_resumed_recording_holds_the_uninterrupted_recordings_values(tmp_path):
    loaded = load_scenario("pick_place")
    run_episode(loaded, 0, [RerunRecorder(path=tmp_path / "full.rrd")])
    run = new_run(loaded, 0)
    assert run_to(run, Stop(100, False, "tick 100", "test"))
    write_run(tmp_path / "t1.snap", run, {}, [])
    resumed = load_run(tmp_path / "t1.snap").run
    drive(resumed, [RerunRecorder(path=tmp_path / "resumed.rrd")])
    full, _ = read_rrd(tmp_path / "full.rrd")
    again, _ = read_rrd(tmp_path / "resumed.rrd")
    # it starts at the snapshot's time, in the state active then, and says so
    assert min(r["tick"] for rows in again.values() for r in rows) == 100
    [mark] = again["/events/resume"]
    assert "resumed from a snapshot at t=1.000 s" in mark["TextLog:text"][0]
    assert again["/state_machine/active"][0]["StateChange:state"] == ["PICK.GRASP.APPROACH"]
    # every value after it is the uninterrupted recording's, row for row
    compared = 0
    for entity in set(full) | set(again):
        if entity == "/events/resume":
            continue
        before = [r for r in full.get(entity, []) if r.get("tick", 0) > 100]
        after = [r for r in again.get(entity, []) if r.get("tick", 0) > 100]
        assert after == before, entity
        compared += len(before)
    assert compared > 5000


def test_a_batch_keeps_each_failures_snapshot_and_reruns_from_it(tmp_path, cli):
    config = BatchConfig(
        scenario="pick_place", episodes=2, out_dir=tmp_path / "batch", workers=1,
        overrides=("guards.workspace.max=[0.95, 0.1, 1.2]",),  # the carried cube leaves it
        record="none", snapshot_on_failure=True,
    )  # fmt: skip
    summary = run_batch(config)
    assert summary.aborted == 2
    lines = {
        ln["seed"]: ln for ln in map(json.loads, (tmp_path / "batch" / "results.jsonl").open())
    }
    for seed, line in lines.items():
        assert line["snapshot"] == f"snapshots/seed_{seed}.snap"
        assert line["snapshot_state"] == "entry of TRANSPORT"  # the last entry before
    path = tmp_path / "batch" / "snapshots" / "seed_0.snap"
    # record="none": the command names no recording (a folder the batch never made)
    assert summary.rerun_command == f"orchestrator run pick_place --from {path}"
    res = cli("run", "--from", str(path), "--json")
    assert res.exit_code == 3  # aborted, as in the batch
    got, want = res.json, lines[0]
    for key in ("wall_time", "worker", "snapshot", "snapshot_state"):
        got.pop(key, None)
        want.pop(key, None)
    # the resumed run measures its invariants from the resume on (docs/invariants.md)
    inv_got, inv_want = got.pop("invariants"), want.pop("invariants")
    assert inv_got["from_t"] > 0.0 and inv_got["ok"] == inv_want["ok"]
    assert got == want
