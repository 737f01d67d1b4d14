"""Every snapshot reader is bounded and every write failure is a message (issue 39, points 4
and 7): /dev/zero, a 2 GB sparse file and crafted headers are refused with exit 2 by
`snapshot show`, `snapshot trust` and `run --from`, and by a live session's restore; a short
signing key is refused; a full disk leaves a message, no temporary file, and a batch whose
`--resume` runs again every episode that could not be recorded."""

from __future__ import annotations

import errno
import json
import os
import resource
import subprocess
import sys
from pathlib import Path

import pytest

from orchestrator.engine.snapshot import SnapshotError, read_snapshot, write_run
from orchestrator.engine.snapshot.signing import KEY_ENV, MIN_KEY_BYTES, signing_key
from orchestrator.engine.snapshot.snapfile import MAX_FILE_BYTES, write_snapshot
from orchestrator.language.load import load_scenario
from orchestrator.live.snapshots import read_session


@pytest.fixture(autouse=True)
def _own_key(tmp_path, monkeypatch):
    monkeypatch.delenv(KEY_ENV, raising=False)
    monkeypatch.setenv("XDG_CONFIG_HOME", str(tmp_path / "config"))


@pytest.fixture
def sparse(tmp_path) -> Path:
    """A 2 GB file that takes no disk: a snapshot's first line, then holes."""
    path = tmp_path / "huge.snap"
    with path.open("wb") as f:
        f.write(b"ORCHESTRATOR-SNAPSHOT 2\n")
        f.truncate(2 << 30)
    return path


def _crafted(tmp_path: Path) -> dict[str, Path]:
    """Headers built to break a reader that trusts them (signed by this user, or not)."""
    files: dict[str, bytes] = {
        "deep": b"ORCHESTRATOR-SNAPSHOT 2\n" + b"[" * 200_000 + b"\n",
        "no_end": b"ORCHESTRATOR-SNAPSHOT 2\n" + b"{" * (2 << 20),
        "huge_int": b'ORCHESTRATOR-SNAPSHOT 2\n{"seed": ' + b"9" * 100_000 + b"}\n",
        "not_utf8": b"ORCHESTRATOR-SNAPSHOT 2\n\xff\xfe{}\n",
    }
    out = {}
    for name, data in files.items():
        out[name] = tmp_path / f"{name}.snap"
        out[name].write_bytes(data)
    for name, header in {
        "wrong_types": {"kind": "run", "t": "soon", "break": 5, "versions": [1]},
        "session_types": {"kind": "session", "seed": "x", "scenario_sha256": None},
    }.items():
        out[name] = tmp_path / f"{name}.snap"
        write_snapshot(out[name], header, b"")  # signed with this user's key
    return out


def _cli(*args: str, env: dict | None = None, limit: int | None = None):
    def preexec() -> None:
        if limit is not None:
            resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))

    return subprocess.run([sys.executable, "-m", "orchestrator.cli", *args], env=env,
                          capture_output=True, text=True, check=False, timeout=120,
                          preexec_fn=preexec)  # fmt: skip  # the timeout: a reader that never ends


def _env(tmp_path: Path, **more: str) -> dict:
    env = {**os.environ, "XDG_CONFIG_HOME": str(tmp_path / "config"), **more}
    if KEY_ENV not in more:
        env.pop(KEY_ENV, None)
    return env


def test_dev_zero_and_a_2_gb_file_are_refused_with_exit_2(cli, tmp_path, sparse):
    for command in (["snapshot", "show"], ["snapshot", "trust"], ["run", "--from"]):
        for path, said in (("/dev/zero", "not a snapshot file"), (str(sparse), "refused unread")):
            res = cli(*command, path)
            assert res.exit_code == 2 and res.exception is None, res.stderr
            assert said in " ".join(res.stderr.split()) and "Traceback" not in res.stderr
    assert sparse.stat().st_size > MAX_FILE_BYTES  # trust wrote nothing over it


def test_a_resume_from_dev_zero_ends_in_a_fresh_process(tmp_path):
    res = _cli("run", "--from", "/dev/zero", env=_env(tmp_path))  # a bounded read ends
    assert res.returncode == 2 and "not a snapshot file" in res.stderr


def test_crafted_headers_are_refused_with_a_message_by_every_reader(cli, tmp_path):
    for name, path in _crafted(tmp_path).items():
        for command in (["snapshot", "show"], ["run", "--from"], ["snapshot", "trust"]):
            res = cli(*command, str(path))
            assert res.exit_code == 2, (name, command, res.stderr, res.exception)
            assert res.exception is None and "Traceback" not in res.stderr
            assert str(path) in " ".join(res.stderr.split())


def test_a_live_restore_reads_within_the_same_limits(tmp_path, sparse):
    loaded = load_scenario("pick_place")
    files = {"/dev/zero": Path("/dev/zero"), "sparse": sparse, **_crafted(tmp_path)}
    for name, path in files.items():
        with pytest.raises(SnapshotError) as caught:
            read_session(path, loaded)
        assert str(path) in str(caught.value), name


def test_a_signing_key_shorter_than_32_bytes_is_refused(tmp_path):
    env = _env(tmp_path, **{KEY_ENV: "k"})
    res = _cli("run", "reach_random", "--break-at", "0.1", "--snapshot",
               str(tmp_path / "x.snap"), env=env)  # fmt: skip
    said = " ".join(res.stderr.split())
    assert res.returncode == 2 and f"at least {MIN_KEY_BYTES} bytes" in said
    assert "Traceback" not in res.stderr and not (tmp_path / "x.snap").exists()


def test_a_full_disk_while_writing_a_snapshot_leaves_a_message_and_no_file(tmp_path, monkeypatch):
    loaded = load_scenario("reach_random")
    from orchestrator.engine.runner import new_run
    from orchestrator.engine.snapshot.stops import Stop, run_to

    run = new_run(loaded, 0)
    stop = Stop(10, False, "test", "test")
    assert run_to(run, stop)
    folder = tmp_path / "snaps"
    folder.mkdir()
    real_write = os.write

    class Full:
        def __init__(self, fd: int, *args, **kwargs) -> None:
            self.fd = fd

        def __enter__(self):
            return self

        def __exit__(self, *exc) -> None:
            os.close(self.fd)

        def write(self, data: bytes) -> int:
            real_write(self.fd, bytes(data[:100]))
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    signing_key()  # the key exists: the disk fills while the snapshot is written
    monkeypatch.setattr("orchestrator.engine.snapshot.snapfile.os.fdopen", Full)
    with pytest.raises(SnapshotError, match="No space left on device"):
        write_run(folder / "x.snap", run, stop.header(), [])
    assert list(folder.iterdir()) == []  # neither the file nor its temporary one


def test_break_on_a_full_disk_says_so_and_leaves_no_file(tmp_path):
    (tmp_path / "out").mkdir()
    res = _cli("run", "reach_random", "--break-at", "0.1", "--snapshot",
               str(tmp_path / "out" / "x.snap"), env=_env(tmp_path), limit=2048)  # fmt: skip
    assert res.returncode == 2 and "Traceback" not in res.stderr, res.stderr
    assert "cannot write the snapshot" in " ".join(res.stderr.split())
    assert list((tmp_path / "out").iterdir()) == []


@pytest.mark.slow  # a whole batch twice (~11 s): the default suite stays under 3 min
def test_a_batch_on_a_full_disk_stops_with_a_message_and_resume_runs_the_rest(tmp_path):
    out = tmp_path / "batch"
    args = ["batch", "reach_random", "-n", "4", "--workers", "1", "--record", "none",
            "--out", str(out)]  # fmt: skip
    res = _cli(*args, env=_env(tmp_path), limit=1400)  # room for about two result lines
    said = " ".join(res.stderr.split())
    assert res.returncode == 2 and "Traceback" not in res.stderr, res.stderr
    assert f"cannot write to {out}" in said and "--resume" in said
    res = _cli(*args, "--resume", env=_env(tmp_path))
    assert res.returncode == 0, res.stderr
    lines = [json.loads(t) for t in (out / "results.jsonl").read_text().splitlines()]
    assert sorted(ln["seed"] for ln in lines) == [0, 1, 2, 3]  # each once, none lost
    assert all(ln["outcome"] != "error" for ln in lines)  # no write error as a result
    assert [p.name for p in out.iterdir() if p.name.endswith(".tmp")] == []


@pytest.mark.slow  # a batch (~5 s): the default suite stays under 3 min
def test_a_batch_that_cannot_snapshot_a_failure_says_so_and_records_why(tmp_path):
    out = tmp_path / "batch"
    out.mkdir()
    (out / "snapshots").write_text("a file where the snapshots' folder would be\n")
    res = _cli("batch", "pick_place", "-n", "1", "--workers", "1", "--record", "none",
               "--set", "guards.workspace.max=[0.95, 0.1, 1.2]",  # the carried cube leaves it
               "--snapshot-on-failure", "--out", str(out), env=_env(tmp_path))  # fmt: skip
    said = " ".join(res.stderr.split())
    assert "Traceback" not in res.stderr, res.stderr
    assert "seed 0: no snapshot (SnapshotError: cannot write the snapshot" in said
    summary = json.loads((out / "summary.json").read_text())
    assert summary["failing_seeds"] == [0]
    assert "cannot write the snapshot" in summary["snapshot_errors"]["0"]
    assert "--from" not in summary["rerun_command"]  # from t = 0, as said


def test_a_snapshot_whose_scenario_changed_or_is_a_device_is_refused(tmp_path, monkeypatch):
    from orchestrator.engine.runner import new_run
    from orchestrator.engine.snapshot import load_run
    from orchestrator.engine.snapshot.stops import Stop, run_to

    scenario = tmp_path / "reach.yaml"
    scenario.write_text(
        (Path(__file__).parent.parent / "scenarios" / "reach_random.yaml").read_text()
    )
    run = new_run(load_scenario(str(scenario)), 0)
    stop = Stop(5, False, "test", "test")
    assert run_to(run, stop)
    path = tmp_path / "x.snap"
    write_run(path, run, stop.header(), [])
    scenario.write_text(scenario.read_text() + "\n# changed\n")
    with pytest.raises(SnapshotError, match="changed since the snapshot was taken"):
        load_run(path)
    snap = read_snapshot(path)
    header = {**snap.header, "recipe": {**snap.header["recipe"], "ref": "/dev/zero"}}
    write_snapshot(path, header, snap.payload)  # signed: only the header's path is crafted
    with pytest.raises(SnapshotError, match="changed since the snapshot was taken"):
        load_run(path)
