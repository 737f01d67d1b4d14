"""A live session's `reload`, `snapshot` and `restore` (live/time_travel.py), stepped by hand.

The hot-reload acceptance: a machine file changed while its task runs takes effect at the
next state entry (the running state finishes as it was); an invalid file is refused with the
validator's errors and the session runs on unchanged.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from orchestrator.engine.snapshot.signing import KEY_ENV
from orchestrator.live.protocol import Command
from orchestrator.live.session import Session

HOLD_LOOP = Path(__file__).parent / "machines" / "hold_loop.yaml"


@pytest.fixture(autouse=True)
def _own_key(tmp_path, monkeypatch):
    monkeypatch.delenv(KEY_ENV, raising=False)
    monkeypatch.setenv("XDG_CONFIG_HOME", str(tmp_path / "config"))


@pytest.fixture
def files(tmp_path) -> dict[str, Path]:
    """The loop, a copy with shorter holds, and one the validator refuses."""
    text = HOLD_LOOP.read_text()
    out = {"loop": tmp_path / "hold_loop.yaml", "fast": tmp_path / "hold_fast.yaml",
           "broken": tmp_path / "hold_broken.yaml"}  # fmt: skip
    out["loop"].write_text(text)
    out["fast"].write_text(text.replace("duration_s: 0.3", "duration_s: 0.1"))
    out["broken"].write_text(text.replace("duration_s: 0.3", "duration_s: fast"))
    return out


def _session(tmp_path: Path, events: list) -> Session:
    def publish(leaf: str, message: dict) -> None:
        if leaf == "events":
            events.append(message)

    return Session("pick_place", "tt", seed=0, speed=0.0, publish=publish,
                   allow_paths=[tmp_path], snapshot_dir=tmp_path / "snaps")  # fmt: skip


def _step(session: Session, ticks: int) -> None:
    """The session's loop, one control tick at a time (no thread, no pacing)."""
    for _ in range(ticks):
        session._drain()
        if session.task is None and session.tasks:
            session._start_next()
        session._tick()
        session._after_tick()


def _held_for(result: dict) -> list[float]:
    """How long each entry of WAIT lasted [s]."""
    times = [0.0, *(tr["t"] for tr in result["transitions"])]
    return [round(b - a, 3) for a, b in zip(times, times[1:], strict=False)]


def test_a_reloaded_parameter_takes_effect_at_the_next_entry(tmp_path, files):
    events: list[dict] = []
    session = _session(tmp_path, events)
    assert session.submit(Command(op="run", machine=str(files["loop"]))).accepted
    _step(session, 5)  # the first hold runs (0.3 s)
    reply = session.submit(Command(op="reload", machine=str(files["fast"])))
    assert reply.accepted, reply.reason
    _step(session, 200)
    result = session.last_result
    assert result is not None and result["outcome"] == "succeeded"
    # the hold that ran finished as it was defined when entered; the next three are 0.1 s
    assert _held_for(result) == [0.3, 0.1, 0.1, 0.1]
    assert [e["event"] for e in events if e["event"].startswith("reload")] == ["reload"]


def test_an_invalid_file_is_refused_with_the_validators_errors_and_nothing_changes(tmp_path, files):
    session = _session(tmp_path, [])
    assert session.submit(Command(op="run", machine=str(files["loop"]))).accepted
    _step(session, 5)
    reply = session.submit(Command(op="reload", machine=str(files["broken"])))
    assert not reply.accepted
    assert f"{files['broken']}:10:12: " in reply.reason
    assert "states.WAIT.with.duration_s: Input should be a valid number" in reply.reason
    _step(session, 200)
    assert session.last_result is not None
    assert _held_for(session.last_result) == [0.3, 0.3, 0.3, 0.3]  # ran on unchanged


def test_a_reload_that_does_not_fit_the_running_task_is_refused(tmp_path, files):
    session = _session(tmp_path, [])
    assert not session.submit(Command(op="reload", machine=str(files["fast"]))).accepted
    other = tmp_path / "renamed.yaml"
    other.write_text(files["loop"].read_text().replace("WAIT", "PAUSE"))
    assert session.submit(Command(op="run", machine=str(files["loop"]))).accepted
    _step(session, 3)
    reply = session.submit(Command(op="reload", machine=str(other)))
    assert not reply.accepted
    assert "WAIT: runs now and is not in the new file (its states: PAUSE, DONE)" in reply.reason


def test_a_session_snapshot_restores_the_world_where_it_was_and_the_arm_holds(tmp_path, files):
    events: list[dict] = []
    session = _session(tmp_path, events)
    assert session.submit(Command(op="run", machine=str(files["loop"]))).accepted
    _step(session, 40)  # inside the second hold
    reply = session.submit(Command(op="snapshot", snapshot="second_hold"))
    assert reply.accepted and reply.snapshot == str(tmp_path / "snaps" / "second_hold.snap")
    _step(session, 1)
    q, t = session.ctx.q.copy(), session.ctx.t
    _step(session, 200)
    assert session.last_result is not None
    assert session.snapshots.wait_for(tmp_path / "snaps" / "second_hold.snap", 120.0)
    session.ctx.data.qpos[0] += 0.3  # the world moved on since
    reply = session.submit(Command(op="restore", snapshot="second_hold", client="me"))
    assert reply.accepted, reply.reason
    _step(session, 1)
    restored = next(e for e in events if e["event"] == "restore")
    assert restored["tick"] == 40 and restored["task"] is None  # the world, not a task
    assert abs(session.ctx.t - t) <= session.ctx.dt_control + 1e-9  # back to the snapshot's time
    assert np.abs(session.ctx.q - q).max() < 1e-3
    _step(session, 100)  # no task: the arm holds where the snapshot had it
    assert np.abs(session.ctx.q - q).max() < 1e-3
    assert session.task is None


@pytest.mark.parametrize(
    ("name", "message"),
    [("../../etc/passwd", "give a plain name"), ("missing", "cannot read the snapshot")],
)
def test_restore_refuses_a_path_or_a_missing_snapshot(tmp_path, name, message):
    session = _session(tmp_path, [])
    reply = session.submit(Command(op="restore", snapshot=name))
    assert not reply.accepted and message in reply.reason


def test_a_snapshot_taken_after_an_estop_restores_with_the_brakes_as_they_were(tmp_path):
    """An e-stop's hold engages the joints' holding brakes (MuJoCo friction loss in the model):
    they are the world's state, recorded and put back, not a different model (found by the
    live protocol's model test: every snapshot after an e-stop was refused as 'another model')."""
    events: list[dict] = []
    session = _session(tmp_path, events)
    assert session.submit(Command(op="estop")).accepted
    _step(session, 30)
    braked = set(session.world.braked)
    assert braked, "the e-stop's hold engages the brakes"
    friction = session.ctx.model.dof_frictionloss.copy()
    assert session.submit(Command(op="reset")).accepted
    _step(session, 5)
    reply = session.submit(Command(op="snapshot", snapshot="after_estop"))
    assert reply.accepted, reply.reason
    _step(session, 1)
    assert session.snapshots.wait_for(tmp_path / "snaps" / "after_estop.snap", 120.0)
    reply = session.submit(Command(op="restore", snapshot="after_estop", client="me"))
    assert reply.accepted, reply.reason
    _step(session, 1)
    assert session.world.braked == braked
    assert np.array_equal(session.ctx.model.dof_frictionloss, friction)
    assert session.submit(Command(op="run", machine="home")).accepted  # brakes released
    _step(session, 3)
    assert not session.world.braked
