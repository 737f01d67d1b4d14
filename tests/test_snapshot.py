"""Snapshots (engine/snapshot): a run broken at a state, written, read back and continued ends
exactly as the run that was never interrupted; and a snapshot file is never unpickled unless
this user's key signed it, this version wrote it and it is of the scenario named.

The fast subset runs here: one machine that has a retry, a parallel state and nested machines
(tests/machines/parallel_pick.yaml), broken inside each; the whole matrix over every bundled
scenario is tests/test_snapshot_matrix.py (slow) and bench/snapshot_identity.py.
"""

from __future__ import annotations

import json
import os
import pickle
import stat
from pathlib import Path

import mujoco
import numpy as np
import pytest

from orchestrator.engine.runner import new_run
from orchestrator.engine.snapshot import SnapshotError, read_snapshot
from orchestrator.engine.snapshot.audit import fingerprint, first_difference, process_values
from orchestrator.engine.snapshot.identity import check, comparable, reference
from orchestrator.engine.snapshot.pickler import dumps, loads
from orchestrator.engine.snapshot.signing import KEY_ENV, key_path
from orchestrator.engine.snapshot.snapfile import write_snapshot
from orchestrator.engine.snapshot.stops import run_to
from orchestrator.language.load import load_scenario
from orchestrator.world.realism import WristForceNoise

MACHINES = Path(__file__).parent / "machines"
PARALLEL_PICK = str(MACHINES / "parallel_pick.yaml")


@pytest.fixture(autouse=True)
def _own_key(tmp_path_factory, monkeypatch):
    """Every test signs with a key of its own (never the user's ~/.config)."""
    monkeypatch.delenv(KEY_ENV, raising=False)
    monkeypatch.setenv("XDG_CONFIG_HOME", str(tmp_path_factory.getbasetemp() / "config"))


# -- the pickler ----------------------------------------------------------------------------
class _Holder:
    """What the hot loop does: views into MjData and into an array of its own, bound once."""

    def __init__(self) -> None:
        self.model = mujoco.MjModel.from_xml_string(
            "<mujoco><worldbody><body><freejoint/><geom size='.1'/></body></worldbody></mujoco>"
        )
        self.data = mujoco.MjData(self.model)
        self.qpos_tail = self.data.qpos[3:7]  # a view into MjData's memory
        self.warnings = self.data.warning.number[1:4]  # a strided field of a sub-struct
        self.flags = np.zeros(3)
        self.flag = self.flags[1:]  # a view of an array of its own


def test_views_into_mujoco_and_into_numpy_arrays_come_back_as_views():
    h = loads(dumps(_Holder()))
    h.data.qpos[3] = 0.25
    h.data.warning.number[2] = 7
    h.flags[2] = 5.0
    assert h.qpos_tail[0] == 0.25  # still MjData's memory, not a copy
    assert h.warnings[1] == 7
    assert h.flag[1] == 5.0
    assert h.data.model is h.model  # the data is on the snapshot's own model


def test_a_restored_world_with_sleeping_bodies_steps_as_the_original():
    # MuJoCo 4.0's MjData pickle loses the sleeping counters: a sleeping body then stopped
    # the step with "mj_sleep: found sleeping tree"; the snapshot patches what it loses
    xml = """<mujoco><option><flag sleep="enable"/></option><worldbody>
      <geom type="plane" size="1 1 .1"/>
      <body pos="0 0 .2"><freejoint/><geom size=".05"/></body>
      <body pos=".3 0 .5"><freejoint/><geom size=".05"/></body></worldbody></mujoco>"""
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    for _ in range(1500):
        mujoco.mj_step(model, data)
    assert data.ntree_awake < model.ntree  # something sleeps
    m2, d2 = loads(dumps((model, data)))
    for _ in range(200):
        mujoco.mj_step(model, data)
        mujoco.mj_step(m2, d2)
    assert d2.qpos.tobytes() == data.qpos.tobytes()
    assert d2.ntree_awake == data.ntree_awake


def test_the_wrist_sensors_noise_stream_goes_on_where_it_was():
    noise = WristForceNoise(0.3, 0.05, 7, 0.002)
    for i in range(700):  # past a block of draws
        noise.offset(i * 0.002)
    again = pickle.loads(pickle.dumps(noise))
    times = [1.4 + i * 0.002 for i in range(1200)]
    assert [again.offset(t) for t in times] == [noise.offset(t) for t in times]


def test_what_cannot_be_pickled_is_named_where_it_is():
    h = _Holder()
    h.callback = lambda: 1  # type: ignore[attr-defined]
    with pytest.raises(SnapshotError, match=r"at \.callback \(a local function"):
        dumps(h)


# -- a resumed run is the uninterrupted run -------------------------------------------------
@pytest.fixture(scope="module")
def parallel_pick():
    loaded = load_scenario(PARALLEL_PICK, faults=["perception_miss@0"])  # SEARCH retries
    result, cases = reference(loaded, 0)
    return loaded, comparable(result), {c.kind: c for c in cases}


@pytest.mark.parametrize("kind", ["parallel", "retry", "nested"])
def test_a_run_resumed_inside_a_parallel_state_a_retry_or_a_nested_machine_ends_the_same(
    parallel_pick, kind, tmp_path
):
    loaded, expected, cases = parallel_pick
    case = cases[kind]  # e.g. parallel: WATCHED.watch.AGAIN while the motion branch moves
    outcome = check(loaded, 0, case, expected, tmp_path)
    assert outcome.identical, f"{case.stop.reason}: {outcome.difference} differs"
    assert expected["outcome"] == "succeeded" and expected["retries"] == {"SEARCH": 1}


def test_a_restored_graph_is_the_original_and_holds_nothing_of_its_process(parallel_pick):
    loaded, _, cases = parallel_pick
    run = new_run(loaded, 0)
    assert run_to(run, cases["parallel"].stop)
    original = fingerprint(run)
    assert first_difference(original, fingerprint(loads(dumps(run)))) is None
    # ids and raw addresses kept as plain ints would read wrong after a restore
    assert process_values(run) == []


def test_the_audit_finds_an_id_kept_as_a_plain_int(parallel_pick):
    loaded, _, _ = parallel_pick
    run = new_run(loaded, 0)
    run.ctx.metrics["cache"] = {id(run.executor): 1}  # what the IK's problem cache once did
    assert any("the id of a Executor" in p for p in process_values(run))


# -- the command line -----------------------------------------------------------------------
@pytest.fixture(scope="module")
def grasp_snapshot(tmp_path_factory):
    """pick_place broken before GRASP (written by `run --break`), and the uninterrupted run's
    JSON."""
    from typer.testing import CliRunner

    from orchestrator.cli import app

    folder = tmp_path_factory.mktemp("snap")
    with pytest.MonkeyPatch.context() as mp:  # the key `_own_key` gives every test
        mp.delenv(KEY_ENV, raising=False)
        mp.setenv("XDG_CONFIG_HOME", str(tmp_path_factory.getbasetemp() / "config"))
        runner = CliRunner()
        path = folder / "before_grasp.snap"
        args = ["run", "pick_place", "--break", "GRASP", "--snapshot", str(path)]
        res = runner.invoke(app, args)
        assert res.exit_code == 6, res.stderr
        full = runner.invoke(app, ["run", "pick_place", "--json"])
    return path, json.loads(full.stdout), res.stderr


def test_break_writes_the_snapshot_says_where_and_exits_6(grasp_snapshot):
    path, _, stderr = grasp_snapshot
    message = " ".join(stderr.split())
    assert f"snapshot written to {path}" in message
    assert "entry of PICK.GRASP (--break GRASP)" in message
    assert f"orchestrator run --from {path}" in message
    header = read_snapshot(path).header
    assert header["scenario"] == "pick_place" and header["state"] == "PICK.SEARCH"
    assert stat.S_IMODE(key_path().stat().st_mode) == 0o600


def test_run_from_continues_to_the_uninterrupted_result(cli, grasp_snapshot):
    path, full, _ = grasp_snapshot
    res = cli("run", "--from", str(path), "--json")
    assert res.exit_code == 0, res.stderr
    resumed = res.json
    full, resumed = dict(full), dict(resumed)
    full.pop("wall_time"), resumed.pop("wall_time")
    assert resumed == full


def test_a_set_at_resume_changes_the_grasp_from_there(cli, grasp_snapshot):
    path, full, _ = grasp_snapshot
    res = cli("run", "--from", str(path), "--set", "grasp_offset=[0, 0, 0.02]", "--json")
    changed = res.json
    assert changed["transitions"][0] == full["transitions"][0]  # SEARCH was before the break
    approach = [tr for tr in changed["transitions"] if tr["from"] == "PICK.GRASP.APPROACH"]
    assert approach[0]["t"] != next(
        tr["t"] for tr in full["transitions"] if tr["from"] == "PICK.GRASP.APPROACH"
    )  # the fingers close 2 cm higher: another approach, another grasp


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--set", "physics.control_hz=50"], "physics.control_hz: a resumed run changes "
         "blackboard keys only"),
        (["--set", "grasp_offsett=[0, 0, 0]"], "grasp_offsett: not a blackboard key of this "
         "machine (valid: "),
        (["--set", "grasp_offset=high"], "'high' is not a vec3"),
        (["--seed", "3"], "a snapshot of seed 0, not seed 3"),
        (["--fault", "estop@1"], "--fault and --event shape a run from its start"),
        (["stack"], "it is a snapshot of scenario 'pick_place'"),
        (["--break", "GRAPS"], "no state 'GRAPS' in machine 'pick_place' (did you mean 'GRASP'?)"),
    ],
    ids=["scenario-path", "unknown-key", "wrong-type", "seed", "fault", "scenario", "break"],
)  # fmt: skip
def test_a_resume_with_a_wrong_option_is_refused_with_exit_2(cli, grasp_snapshot, args, message):
    path, _, _ = grasp_snapshot
    scenario = [args.pop(0)] if args[0] == "stack" else []
    res = cli("run", *scenario, "--from", str(path), *args)
    assert res.exit_code == 2
    assert message in " ".join(res.stderr.split())
    assert "Traceback" not in res.stderr


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--break", "GRASP@0"], "N of STATE@N must be a whole number >= 1"),
        (["--break-on", "forces"], "forces: not a guard (valid: guard, estop, collision"),
        (["--break-at", "nan"], "give a finite time >= 0"),
        (["--break", "GRASP", "--rrd", "x.rrd"], "--rrd records a run to its end"),
        (["--snapshot", "x.snap"], "--snapshot names the file a break point writes"),
    ],
)
def test_a_break_option_that_cannot_be_met_is_refused_with_exit_2(cli, args, message):
    res = cli("run", "pick_place", *args)
    assert res.exit_code == 2
    assert message in " ".join(res.stderr.split())


# -- hostile files ----------------------------------------------------------------------------
def _resume(cli, path: Path):
    res = cli("run", "--from", str(path))
    return res.exit_code, " ".join(res.stderr.split())


def test_a_tampered_snapshot_is_refused_unread(cli, grasp_snapshot, tmp_path):
    path, _, _ = grasp_snapshot
    data = bytearray(path.read_bytes())
    data[-100] ^= 1  # one bit of the payload
    bad = tmp_path / "tampered.snap"
    bad.write_bytes(bytes(data))
    code, message = _resume(cli, bad)
    assert code == 2 and "not signed with this user's snapshot key" in message
    assert "loading a pickle runs the code it names" in message


def test_a_pickle_signed_with_another_key_never_runs(cli, tmp_path, monkeypatch):
    marker = tmp_path / "pwned"

    class Evil:
        def __reduce__(self):
            return (os.system, (f"touch {marker}",))

    path = tmp_path / "evil.snap"
    monkeypatch.setenv(KEY_ENV, "someone else's key")
    write_snapshot(path, {"kind": "run", "versions": {}}, pickle.dumps(Evil()))
    monkeypatch.delenv(KEY_ENV)
    code, message = _resume(cli, path)
    assert code == 2 and "not signed with this user's snapshot key" in message
    assert not marker.exists()


def test_a_snapshot_of_another_version_is_refused_naming_what_differs(
    cli, grasp_snapshot, tmp_path
):
    path, _, _ = grasp_snapshot
    snap = read_snapshot(path)
    header = {**snap.header, "versions": {**snap.header["versions"], "mujoco": "3.3.0"}}
    old = tmp_path / "old.snap"
    write_snapshot(old, header, snap.payload)  # signed with this user's key
    code, message = _resume(cli, old)
    assert code == 2 and "written by another version" in message
    assert "mujoco: snapshot 3.3.0, here " in message


@pytest.mark.parametrize(
    ("data", "message"),
    [
        (b"not a snapshot\n", "not a snapshot file"),
        (b"ORCHESTRATOR-SNAPSHOT 9\n{}\n", "snapshot format '9', this version reads format 1"),
        (b"ORCHESTRATOR-SNAPSHOT 1\n{not json\n", "broken snapshot header"),
    ],
)
def test_files_that_are_no_snapshot_are_refused(cli, tmp_path, data, message):
    path = tmp_path / "x.snap"
    path.write_bytes(data)
    code, said = _resume(cli, path)
    assert code == 2 and message in said


def test_a_key_file_others_can_read_is_refused(cli, grasp_snapshot):
    path, _, _ = grasp_snapshot
    key = key_path()
    key.chmod(0o644)
    try:
        code, message = _resume(cli, path)
    finally:
        key.chmod(0o600)
    assert code == 2 and "the snapshot key is open to other users" in message
    assert f"chmod 600 {key}" in message


def test_snapshot_show_reads_the_header_without_unpickling(cli, grasp_snapshot):
    path, _, _ = grasp_snapshot
    res = cli("snapshot", "show", str(path), "--json")
    assert res.exit_code == 0
    shown = res.json
    assert shown["scenario"] == "pick_place" and shown["signed_by_you"] is True
    assert shown["break"]["option"] == "--break GRASP"


def test_a_snapshot_trusted_with_snapshot_trust_resumes(cli, grasp_snapshot, tmp_path, monkeypatch):
    path, full, _ = grasp_snapshot
    other = tmp_path / "from_a_colleague.snap"
    snap = read_snapshot(path)
    monkeypatch.setenv(KEY_ENV, "a colleague's key")
    write_snapshot(other, snap.header, snap.payload)
    monkeypatch.delenv(KEY_ENV)
    assert _resume(cli, other)[0] == 2
    assert cli("snapshot", "trust", str(other)).exit_code == 0
    res = cli("run", "--from", str(other), "--json")
    assert res.exit_code == 0 and res.json["transitions"] == full["transitions"]
