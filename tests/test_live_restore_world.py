"""A live session's world after a `restore` (issue 39, found by the live protocol's model test
in tests/test_live_model.py): the arm is driven by what its encoders read of it, whatever ran
before; a status window that spans the restore covers the steps on both sides of it.

Before: the restore replaced the encoders' exact reading (a tuple of views into MjData) by the
snapshot's copies, so the controller read the snapshot's joint state forever after and the arm
ran open-loop: a 0.2 rad/s joint move (recover's UNWIND) was aborted by `joint_velocity` with
the wrist at 2.6 rad/s, and an e-stopped, braked arm swung at 3.7 rad/s. Stepped by hand
(simulated ticks, no wall clock)."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pytest

from orchestrator.engine.snapshot.signing import KEY_ENV
from orchestrator.language.load import load_scenario
from orchestrator.live.protocol import Command
from orchestrator.live.session import Session
from orchestrator.live.task import Task

from .live_model import latched_runs
from .live_server import SETTLE_S, STILL_RAD_S, motion_while_latched
from .test_recovery import PAST_THE_STOP


@pytest.fixture(autouse=True)
def _own_key(tmp_path, monkeypatch):
    monkeypatch.delenv(KEY_ENV, raising=False)
    monkeypatch.setenv("XDG_CONFIG_HOME", str(tmp_path / "config"))


def _session(tmp_path: Path, events: list) -> Session:
    def publish(leaf: str, message: dict) -> None:
        if leaf == "events":
            events.append(message)

    return Session("pick_place", "restored", seed=3, speed=0.0, publish=publish,
                   snapshot_dir=tmp_path / "snaps", allow_paths=[tmp_path])  # fmt: skip


def _step(session: Session, ticks: int, measure: bool = False) -> list[float]:
    """`ticks` passes of the session's loop; with `measure`, the arm's peak joint speed over
    the physics steps of each [rad/s] (a status window per tick)."""
    peaks = []
    for _ in range(ticks):
        session._drain()
        if session.task is None and session.tasks and not (session.estopped or session.error):
            session._start_next()
        session._tick()
        session._after_tick()
        if measure:
            peaks.append(session.probe.window()["peak"])
    return peaks


def _snapshot(session: Session, events: list, name: str) -> None:
    assert session.submit(Command(op="snapshot", snapshot=name)).accepted
    _step(session, 1)
    deadline = time.monotonic() + 120.0
    while not any(e["event"] == "snapshot" and e["snapshot"].endswith(f"/{name}.snap")
                  for e in events):  # fmt: skip
        assert time.monotonic() < deadline, f"snapshot {name} not written in 120 s"
        time.sleep(0.05)


def _restore(session: Session, name: str) -> None:
    reply = session.submit(Command(op="restore", snapshot=name))
    assert reply.accepted, reply.reason
    _step(session, 1)


def test_recover_gets_a_restored_blocked_arm_out(tmp_path):
    """The live model's finding: a session BLOCKED by `joint_limits` after a restore, and
    `recover`'s 0.2 rad/s joint-space move aborted by `joint_velocity` within 0.1 s."""
    events: list[dict] = []
    session = _session(tmp_path, events)
    (tmp_path / "past_the_stop.yaml").write_text(PAST_THE_STOP)
    loaded = load_scenario("pick_place", machine=str(tmp_path / "past_the_stop.yaml"),
                           allow_paths=[tmp_path])  # fmt: skip
    session.tasks.append(Task("local-1", loaded, session.cell, "past_the_stop"))
    for _ in range(300):
        _step(session, 1)
        if session.task is None and session.state == "BLOCKED":
            break
    assert session.status()["blocked"]["guard"] == "joint_limits", session.status()
    _snapshot(session, events, "blocked")
    _restore(session, "blocked")
    assert session.state == "BLOCKED"

    assert session.submit(Command(op="recover", client="test")).accepted
    session.probe.window()  # the recovery's own steps from here
    peaks = []
    for _ in range(600):
        peaks += _step(session, 1, measure=True)
        if session.task is None and not session.tasks:
            break
    result = session.last_result
    assert result["machine"] == "recover" and result["outcome"] == "succeeded", result
    assert max(peaks) < 0.3, f"the arm reached {max(peaks):.3f} rad/s in a 0.2 rad/s recovery"
    _step(session, 10)
    assert session.state == "IDLE", session.status()


def test_an_estop_after_a_restore_holds_the_arm(tmp_path):
    """A mid-pick snapshot restored (the arm moving at ~1 rad/s), then an e-stop: the arm is
    still from `SETTLE_S` after the stop on, on every physics step."""
    events: list[dict] = []
    session = _session(tmp_path, events)
    assert session.submit(Command(op="run")).accepted
    _step(session, 40)
    _snapshot(session, events, "moving")
    _step(session, 80)
    _restore(session, "moving")
    _step(session, 5)
    session.estop("test")
    _step(session, 1)
    assert session.state == "ESTOPPED"
    stop_t = session.last_estop["t"]
    settle_ticks = int(np.ceil(SETTLE_S / 0.01))
    _step(session, settle_ticks)
    session.probe.window()  # the next window starts SETTLE_S after the stop
    after = _step(session, 60, measure=True)
    assert max(after) <= STILL_RAD_S, (
        f"the arm moved at {max(after):.3f} rad/s while ESTOPPED, from {stop_t + SETTLE_S} s"
    )


def test_a_status_window_across_a_restore_covers_both_sides(tmp_path):
    """A window with steps before a restore (later simulated time), the restored arm's
    steps and an e-stop: its times span all of them, so the model does not take the restored
    pick's motion before the e-stop for motion while ESTOPPED (the long profile's
    `estop_motion` finding: a window read "46.382..45.61 s", stop at 45.59 s)."""
    events: list[dict] = []
    session = _session(tmp_path, events)
    assert session.submit(Command(op="run")).accepted
    _step(session, 40)
    _snapshot(session, events, "mid")
    _step(session, 80)
    statuses = [session.published_status()]  # a window ends; the next one begins
    _step(session, 3)
    t_before = session.ctx.t
    _restore(session, "mid")
    t_restored = session.ctx.t
    assert t_restored < t_before - 0.5
    _step(session, 5)
    session.estop("test")
    _step(session, 2)
    statuses.append(session.published_status())
    window = statuses[-1]["arm_speed"]
    assert window["t0"] <= t_restored + 1e-6 and window["t1"] >= t_before - 1e-6, window
    assert window["peak"] > STILL_RAD_S  # the restored pick moved before the e-stop
    ((run, stop_t),) = latched_runs(statuses)
    assert not motion_while_latched(run, stop_t), window


def test_a_run_accepted_before_a_restore_is_applied_runs_on_the_restored_world(tmp_path):
    """A `run` made for the world before a restore and started after it ran on the replaced
    world: a second world stepped beside the session's, with its own time (the long
    profile's windows alternated between 37.9-39.2 s and 38.1-38.3 s while ESTOPPED)."""
    events: list[dict] = []
    session = _session(tmp_path, events)
    _step(session, 20)
    _snapshot(session, events, "early")
    _step(session, 100)
    assert session.submit(Command(op="restore", snapshot="early")).accepted
    assert session.submit(Command(op="run")).accepted  # made for the world before the restore
    _step(session, 1)
    task = session.task
    assert task is not None and task.ctx is not None
    assert task.cell is session.cell
    assert task.ctx.t == session.ctx.t < 0.5  # one world, one clock: the restored one
    session.probe.window()
    _step(session, 30)
    window = session.probe.window()
    assert window["t1"] == pytest.approx(session.ctx.t) and window["peak"] > STILL_RAD_S
