"""Snapshots of a live session are written off the control loop, under a cap (issue 39):
a burst of them does not delay an e-stop by a control tick, and the cap's refusal names it.
Stepped by hand (simulated ticks, no wall clock)."""

from __future__ import annotations

import time
from pathlib import Path

import pytest

from orchestrator.engine.snapshot.signing import KEY_ENV
from orchestrator.live.protocol import Command
from orchestrator.live.session import Session


@pytest.fixture(autouse=True)
def _own_key(tmp_path, monkeypatch):
    monkeypatch.delenv(KEY_ENV, raising=False)
    monkeypatch.setenv("XDG_CONFIG_HOME", str(tmp_path / "config"))


def _session(tmp_path: Path, events: list, **kw) -> Session:
    def publish(leaf: str, message: dict) -> None:
        if leaf == "events":
            events.append(message)

    return Session("pick_place", "snaps", seed=0, speed=0.0, publish=publish,
                   snapshot_dir=tmp_path / "snaps", **kw)  # fmt: skip


def _step(session: Session, ticks: int) -> None:
    for _ in range(ticks):
        session._drain()
        if session.task is None and session.tasks:
            session._start_next()
        session._tick()
        session._after_tick()


def _written(events: list, n: int, timeout: float = 600.0) -> list[dict]:
    """The first `n` snapshot / snapshot_failed events, waited for in wall time: a writer runs
    niced (WRITER_NICE), so beside busy processes it gets a sliver of a core; the bound holds
    under load, a writer that never reports still fails the test."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        done = [e for e in events if e["event"] in ("snapshot", "snapshot_failed")]
        if len(done) >= n:
            return done
        time.sleep(0.05)
    raise AssertionError(f"{n} snapshots not written in {timeout} s")


def _burst_then_estop(tmp_path: Path, events: list) -> Session:
    """A pick runs, 30 snapshots are sent, then an e-stop: applied at the next tick."""
    session = _session(tmp_path, events)
    assert session.submit(Command(op="run")).accepted
    _step(session, 30)
    assert session.state in ("MOVING", "GRASPING")
    for n in range(30):
        assert session.submit(Command(op="snapshot", snapshot=f"burst{n}")).accepted
    _step(session, 2)  # the burst is applied: writers are forked, the rest wait
    assert session.submit(Command(op="estop", client="guard")).accepted
    _step(session, 1)
    assert session.state == "ESTOPPED"
    assert session.last_estop is not None and session.last_estop["ticks"] <= 1
    return session


def test_an_estop_behind_30_snapshots_takes_effect_at_the_next_tick(tmp_path):
    events: list[dict] = []
    session = _burst_then_estop(tmp_path, events)
    session.snapshots.close()  # the session ends: writers in flight finish, the rest dropped
    done = _written(events, 30)
    written = [e for e in done if e["event"] == "snapshot"]
    # one writer forked per tick at most: the burst saw three ticks (two, then the e-stop's);
    # a third writer is forked there when one of the first two has already finished
    assert 1 <= len(written) <= 3
    ticks = [e["tick"] for e in written]
    assert len(set(ticks)) == len(ticks), ticks  # each captured at a tick of its own
    reasons = [e["reason"] for e in done if e["event"] == "snapshot_failed"]
    assert all("shut down" in why for why in reasons), sorted(set(reasons))
    files = sorted(p.name for p in (tmp_path / "snaps").iterdir())
    assert files == sorted(Path(e["snapshot"]).name for e in written)  # no temp file left


@pytest.mark.slow
def test_a_burst_of_30_snapshots_is_written_in_full(tmp_path):
    events: list[dict] = []
    session = _burst_then_estop(tmp_path, events)
    while session.snapshots.pending:  # one writer forked per tick, two at a time
        _step(session, 1)
        time.sleep(0.01)
    done = _written(events, 30)
    assert [e["event"] for e in done] == ["snapshot"] * 30
    assert len({e["snapshot"] for e in done}) == 30
    assert all((tmp_path / "snaps" / f"burst{n}.snap").is_file() for n in range(30))
    assert not [p for p in (tmp_path / "snaps").iterdir() if p.name.startswith(".")]


def test_the_count_cap_refuses_by_name(tmp_path):
    session = _session(tmp_path, [], snapshot_count=3)
    for n in range(3):
        assert session.submit(Command(op="snapshot", snapshot=f"s{n}")).accepted
    reply = session.submit(Command(op="snapshot", snapshot="s3"))
    assert not reply.accepted
    assert "cap of 3 snapshots" in reply.reason and "--snapshot-count" in reply.reason


def test_the_bytes_cap_refuses_by_name_once_reached(tmp_path):
    events: list[dict] = []
    session = _session(tmp_path, events, snapshot_bytes=2**20)
    assert session.submit(Command(op="snapshot", snapshot="first")).accepted
    _step(session, 1)
    size = _written(events, 1)[0]["bytes"]
    assert size > 0
    session.snapshots.max_bytes = size + size // 2  # room for one, not for two
    reply = session.submit(Command(op="snapshot", snapshot="second"))
    assert not reply.accepted
    assert "cap of" in reply.reason and "--snapshot-mb" in reply.reason


def test_an_estopped_snapshot_does_not_latch_the_session_it_is_restored_in(tmp_path):
    events: list[dict] = []
    session = _session(tmp_path, events)
    assert session.submit(Command(op="run")).accepted
    _step(session, 20)
    session.submit(Command(op="estop"))
    _step(session, 1)
    assert session.submit(Command(op="snapshot", snapshot="stopped")).accepted
    _step(session, 1)
    assert session.submit(Command(op="reset")).accepted
    _step(session, 1)
    assert session.state != "ESTOPPED"
    _written(events, 1)
    reply = session.submit(Command(op="restore", snapshot="stopped"))
    assert reply.accepted, reply.reason
    _step(session, 1)
    assert session.state != "ESTOPPED"  # an e-stopped snapshot does not latch the session
    assert any(e["event"] == "restore" for e in events)


def test_a_restore_names_the_snapshots_task_and_does_not_resume_it(tmp_path):
    events: list[dict] = []
    session = _session(tmp_path, events)
    reply = session.submit(Command(op="run"))
    assert reply.accepted
    _step(session, 20)
    assert session.task is not None and session.state == "MOVING"
    running = session.task.id
    assert session.submit(Command(op="snapshot", snapshot="mid")).accepted
    _step(session, 1)
    _written(events, 1)
    reply = session.submit(Command(op="restore", snapshot="mid"))
    assert reply.accepted, reply.reason
    _step(session, 3)
    (restored,) = [e for e in events if e["event"] == "restore"]
    assert restored["snapshot_task"]["id"] == running  # which task the snapshot was taken in
    assert restored["task"] is None and session.task is None  # the world back, no task
    assert session.state == "IDLE"
