"""Snapshots (engine/snapshot): a run broken at a state, written, read back and continued ends
exactly as the run that was never interrupted; a snapshot is data (a JSON header and numeric
arrays), resumed only when this user's key signed it, this version wrote it, it is of the
scenario named and the run rebuilt from that scenario holds the recorded state.

The fast subset runs here: one machine that has a retry, a parallel state and nested machines
(tests/machines/parallel_pick.yaml), broken inside each; the whole matrix over every bundled
scenario is tests/test_snapshot_matrix.py (slow) and bench/snapshot_identity.py.
"""

from __future__ import annotations

import io
import json
import os
import stat
import zipfile
from pathlib import Path

import numpy as np
import pytest

from orchestrator.engine.runner import new_run
from orchestrator.engine.snapshot import SnapshotError, load_run, read_snapshot, write_run
from orchestrator.engine.snapshot.data import decode, encode
from orchestrator.engine.snapshot.identity import check, comparable, reference
from orchestrator.engine.snapshot.signing import KEY_ENV, key_path
from orchestrator.engine.snapshot.snapfile import write_snapshot
from orchestrator.engine.snapshot.stops import Stop, run_to
from orchestrator.language.load import load_scenario

from .cli_runner import invoke

MACHINES = Path(__file__).parent / "machines"
PARALLEL_PICK = str(MACHINES / "parallel_pick.yaml")


@pytest.fixture(autouse=True)
def _own_key(tmp_path_factory, monkeypatch):
    """Every test signs with a key of its own (never the user's ~/.config)."""
    monkeypatch.delenv(KEY_ENV, raising=False)
    monkeypatch.setenv("XDG_CONFIG_HOME", str(tmp_path_factory.getbasetemp() / "config"))


# -- the data ---------------------------------------------------------------------------------
def test_a_run_snapshot_holds_data_only_and_names_each_running_skill(tmp_path):
    loaded = load_scenario("pick_place")
    run = new_run(loaded, 0)
    assert run_to(run, Stop(300, False, "test", "test"))
    path = tmp_path / "x.snap"
    write_run(path, run, Stop(300, False, "test", "test").header(), [])
    arrays = read_snapshot(path).arrays()
    assert all(a.dtype.kind in "biuf" for a in arrays.values())  # numbers, no objects
    state = json.loads(arrays["state"].tobytes())
    skill = next(iter(state["skills"].values()))
    assert skill["skill"].startswith("orchestrator.skills.") and isinstance(skill["state"], dict)
    assert state["leaf"] == run.executor.leaf and set(state["generators"]) >= {".ctx.cell.rng"}
    with zipfile.ZipFile(io.BytesIO(read_snapshot(path).payload)) as zf:
        for name in zf.namelist():  # every member loads as an array without pickle
            np.lib.format.read_array(zf.open(name), allow_pickle=False)


def test_a_rebuilt_run_that_differs_from_the_recorded_state_is_refused(tmp_path):
    loaded = load_scenario("pick_place")
    run = new_run(loaded, 0)
    stop = Stop(200, False, "test", "test")
    assert run_to(run, stop)
    run.ctx.rng.random()  # the recorded generator is one draw ahead of any rebuilt run
    path = tmp_path / "x.snap"
    write_run(path, run, stop.header(), [])
    with pytest.raises(SnapshotError, match=r"does not hold the recorded state .*\.ctx\.cell\.rng"):
        load_run(path)


def test_a_skills_default_state_is_its_plain_data():
    class Probe:
        def __init__(self) -> None:
            self.t0, self.name, self.path = 1.5, "a", np.arange(3.0)
            self.params = {"k": [1, 2]}
            self.callback = print  # not data: left out

    from orchestrator.skills.plain_state import plain_state

    state = plain_state(Probe())
    assert set(state) == {"t0", "name", "path", "params"}
    tree, arrays = encode(state, "p/")
    back = decode(json.loads(json.dumps(tree)), arrays)
    assert back["path"].tobytes() == np.arange(3.0).tobytes() and back["t0"] == 1.5


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


# -- the command line -----------------------------------------------------------------------
@pytest.fixture(scope="module")
def grasp_snapshot(tmp_path_factory):
    """pick_place broken before GRASP (written by `run --break`), and the uninterrupted run's
    JSON."""
    folder = tmp_path_factory.mktemp("snap")
    with pytest.MonkeyPatch.context() as mp:  # the key `_own_key` gives every test
        mp.delenv(KEY_ENV, raising=False)
        mp.setenv("XDG_CONFIG_HOME", str(tmp_path_factory.getbasetemp() / "config"))
        path = folder / "before_grasp.snap"
        args = ["run", "pick_place", "--break", "GRASP", "--snapshot", str(path)]
        res = invoke(args)
        assert res.exit_code == 6, res.stderr
        full = invoke(["run", "pick_place", "--json"])
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
    # the invariants of a resumed run are measured from the resume on (docs/invariants.md)
    inv_full, inv_resumed = full.pop("invariants"), resumed.pop("invariants")
    assert inv_resumed["from_t"] > 0.0 and "from_t" not in inv_full
    assert inv_resumed["ok"] == inv_full["ok"]
    assert resumed == full


def test_a_set_at_resume_changes_the_grasp_from_there(cli, grasp_snapshot):
    path, full, _ = grasp_snapshot
    res = cli("run", "--from", str(path), "--set", "grasp_offset=[0, 0, 0.02]", "--json")
    changed = res.json
    assert changed["transitions"][0] == full["transitions"][0]  # SEARCH was before the break
    # the fingers close 2 cm higher: another grasp (the approach may end on the same tick: its
    # slow last stretch, just above the grasp pose, moves with it)
    close = [tr for tr in changed["transitions"] if tr["from"] == "PICK.GRASP.CLOSE"]
    assert close[0]["t"] != next(
        tr["t"] for tr in full["transitions"] if tr["from"] == "PICK.GRASP.CLOSE"
    )


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


def test_a_pickle_in_a_snapshot_never_runs_even_signed_with_this_users_key(
    cli, grasp_snapshot, tmp_path
):
    import pickle

    marker = tmp_path / "pwned"

    class Evil:
        def __reduce__(self):
            return (os.system, (f"touch {marker}",))

    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w") as zf:  # an .npz whose one array is an object array
        zf.writestr("state.npy", _npy_object_bytes(pickle.dumps([Evil()])))
    path = tmp_path / "evil.snap"
    header = read_snapshot(grasp_snapshot[0]).header  # a real run's header: it gets that far
    write_snapshot(path, header, buf.getvalue())  # signed with this user's own key
    code, message = _resume(cli, path)
    assert code == 2 and "broken snapshot payload" in message
    assert not marker.exists()
    payload = read_snapshot(path)
    with pytest.raises(SnapshotError, match="broken snapshot payload"):
        payload.arrays()
    assert not marker.exists()


def _npy_object_bytes(pickled: bytes) -> bytes:
    """An .npy file of an object array: numpy's header, then the pickle numpy would load."""
    out = io.BytesIO()
    np.lib.format.write_array_header_1_0(
        out, {"descr": "|O", "fortran_order": False, "shape": (1,)}
    )
    return out.getvalue() + pickled


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
        (b"ORCHESTRATOR-SNAPSHOT 9\n{}\n", "snapshot format '9', this version reads format 2"),
        (b"ORCHESTRATOR-SNAPSHOT 1\n{}\n", "format 1 snapshots were pickles"),
        (b"ORCHESTRATOR-SNAPSHOT 2\n{not json\n", "broken snapshot header"),
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


def test_snapshot_show_reads_the_header(cli, grasp_snapshot):
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
    monkeypatch.setenv(KEY_ENV, "a colleague's key, at least 32 bytes long")
    write_snapshot(other, snap.header, snap.payload)
    monkeypatch.delenv(KEY_ENV)
    assert _resume(cli, other)[0] == 2
    assert cli("snapshot", "trust", str(other)).exit_code == 0
    res = cli("run", "--from", str(other), "--json")
    assert res.exit_code == 0 and res.json["transitions"] == full["transitions"]
