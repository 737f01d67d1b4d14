"""A session's queue policy, task ids and per-owner watchdog, stepped by hand (no transport)."""

from __future__ import annotations

import re
import types

import pytest

from orchestrator.live.protocol import Command
from orchestrator.live.session import Session

REACH = ["target=[0.45, -0.25, 0.55]"]


class WallClock:
    """The wall clock the session and its tasks read, moved on by the test: a watchdog judged
    on it trips when the test says time has passed, not when a loaded machine happened to
    hold the test's thread for a fifth of a second."""

    def __init__(self) -> None:
        self.now = 1000.0

    def perf_counter(self) -> float:
        return self.now

    def advance(self, seconds: float) -> None:
        self.now += seconds


@pytest.fixture
def wall(monkeypatch) -> WallClock:
    from orchestrator.live import session, supervision, task

    clock = WallClock()
    fake = types.SimpleNamespace(perf_counter=clock.perf_counter)
    for module in (session, supervision, task):  # every module that reads the wall clock
        monkeypatch.setattr(module, "time", fake)
    return clock


def _cmd(op: str, **kw) -> Command:
    return Command(op=op, **kw)  # type: ignore[arg-type]


class Events:
    """Captures what the session publishes on `events`."""

    def __init__(self) -> None:
        self.got: list[dict] = []

    def __call__(self, leaf: str, msg: dict) -> None:
        if leaf == "events":
            self.got.append(msg)

    def of(self, event: str) -> list[dict]:
        return [m for m in self.got if m["event"] == event]


def _cycle(session: Session, n: int = 1) -> None:
    """`n` turns of the session's loop, without its pacing."""
    for _ in range(n):
        session._drain()
        session._watchdog()
        if session.task is None and session.tasks and not (session.estopped or session.error):
            session._start(session.tasks[0])
            session.tasks.popleft()
        session._tick()


def _session(**kw) -> tuple[Session, Events]:
    events = Events()
    return Session("pick_place", "q", seed=3, speed=0.0, publish=events, **kw), events


def test_a_run_while_busy_is_refused_naming_the_running_task():
    session, _ = _session()
    first = session.submit(_cmd("run", machine="reach", set=REACH))
    assert first.accepted
    pending = session.submit(_cmd("run", machine="home"))
    assert not pending.accepted
    assert pending.reason.startswith(f"busy: task {first.task} (reach) is about to start")
    _cycle(session)
    busy = session.submit(_cmd("run", machine="home"))
    assert busy.reason == (
        f"busy: task {first.task} (reach) is running (queue policy: reject while busy); send "
        "with --preempt to stop it under control and run this one, or serve with --queue N"
    )


def test_a_bounded_queue_takes_n_tasks_behind_the_running_one():
    session, _ = _session(queue_limit=2)
    ids = [session.submit(_cmd("run", machine="home")).task for _ in range(3)]
    assert all(ids)
    _cycle(session)
    assert session.task.id == ids[0] and [t.id for t in session.tasks] == ids[1:]
    full = session.submit(_cmd("run", machine="home"))
    assert not full.accepted and "and 2 task(s) wait (serve --queue 2)" in full.reason


def test_a_flood_of_runs_while_busy_is_refused_without_loading_anything(monkeypatch):
    session, _ = _session()
    assert session.submit(_cmd("run", machine="home")).accepted
    monkeypatch.setattr(session, "_prepare", lambda cmd: pytest.fail("loaded while busy"))
    replies = [session.submit(_cmd("run", machine="reach", set=REACH)) for _ in range(200)]
    assert not any(r.accepted for r in replies) and all("busy" in r.reason for r in replies)


def test_preempt_stops_the_running_task_drops_the_queue_and_runs_next():
    session, events = _session(queue_limit=1)
    first = session.submit(_cmd("run", machine="reach", set=REACH)).task
    queued = session.submit(_cmd("run", machine="home")).task
    _cycle(session, 20)
    assert session.task.id == first and session.state == "MOVING"
    new = session.submit(_cmd("run", machine="home", preempt=True))
    assert new.accepted
    _cycle(session)
    dropped = [m for m in events.of("task_end") if m["task"] == queued]
    assert dropped == [{"event": "task_end", "task": queued, "result": None,
                        "reason": f"not started: preempted by task {new.task}"}]  # fmt: skip
    for _ in range(3000):
        _cycle(session)
        if session.last_result and session.last_result["task"] == new.task:
            break
    ends = {m["task"]: m["result"] for m in events.of("task_end") if m["result"]}
    assert ends[first]["outcome"] == "failed"
    assert ends[first]["metrics"]["stopped_by"] == f"preempted by task {new.task}"
    assert ends[new.task]["outcome"] == "succeeded"
    starts = [m["task"] for m in events.of("task_start")]
    assert starts == [first, new.task]  # the queued one never started


def test_task_ids_are_unique_across_sessions_of_the_same_name():
    a, _ = _session()
    b, _ = _session()
    assert a.epoch != b.epoch
    ida = a.submit(_cmd("run", machine="home")).task
    idb = b.submit(_cmd("run", machine="home")).task
    assert ida == f"{a.epoch}-1" and idb == f"{b.epoch}-1" and ida != idb


def _run_owned(session: Session, owner: str) -> str:
    reply = session.submit(_cmd("run", machine="reach", set=REACH, owner=owner, client="planner"))
    assert reply.accepted
    _cycle(session)
    return reply.task


def test_a_bystanders_heartbeats_do_not_keep_a_silent_owners_task_alive(wall):
    session, events = _session(watchdog_s=0.2)
    task = _run_owned(session, "owner-token")  # started: the owner's silence counts from here
    t0 = wall.now
    while session.error is None and wall.now - t0 < 5.0:
        session.heartbeat("bystander-token")
        session.heartbeat("")
        wall.advance(0.01)
        _cycle(session)
    tripped = wall.now - t0
    assert session.error is not None and 0.2 <= tripped <= 0.2 + 0.01 + 1e-9
    assert session.error.startswith(f"watchdog: no heartbeat from task {task}'s owner (planner)")
    assert len(events.of("watchdog")) == 1


def test_the_owners_heartbeats_keep_its_task_alive(wall):
    session, _ = _session(watchdog_s=0.2)
    _run_owned(session, "owner-token")
    t0 = wall.now
    while wall.now - t0 < 0.6 and session.task is not None:
        session.heartbeat("owner-token")
        wall.advance(0.01)
        _cycle(session)
    assert wall.now - t0 >= 0.6 - 1e-9, "the task ended before the watchdog was tried"
    assert session.error is None


def test_a_queued_task_whose_owner_fell_silent_is_dropped_unstarted(wall):
    session, events = _session(watchdog_s=0.2, queue_limit=1)
    running = _run_owned(session, "a")
    queued = session.submit(_cmd("run", machine="home", owner="b", client="gone")).task
    t0 = wall.now
    while wall.now - t0 < 0.5:
        session.heartbeat("a")
        wall.advance(0.01)
        _cycle(session)
    assert session.task.id == running and not session.tasks and session.error is None
    (end,) = [m for m in events.of("task_end") if m["task"] == queued]
    assert end["result"] is None
    assert re.fullmatch(r"not started: its owner \(gone\) sent no heartbeat for 0\.\d+ s "
                        r"\(watchdog 0\.2 s\)", end["reason"]), end["reason"]  # fmt: skip


def test_a_bug_applying_a_command_stops_the_task_and_reports_it(monkeypatch):
    session, events = _session()
    _run_owned(session, "o")
    _cycle(session, 10)

    def broken(reason: str) -> None:
        raise RuntimeError("a bug in stop")

    monkeypatch.setattr(session.task, "stop", broken)
    assert session.submit(_cmd("stop")).accepted
    _cycle(session)
    assert session.state == "ERROR"
    assert session.error == "internal error applying stop: RuntimeError: a bug in stop"
    for _ in range(500):
        _cycle(session)
        if session.task is None:
            break
    result = session.last_result
    assert result["outcome"] == "aborted" and result["reason"]["guard"] == "internal_error"
    assert events.of("internal_error")[0]["message"] == session.error
    assert session.submit(_cmd("reset")).accepted  # the loop goes on


def test_an_estop_from_any_thread_wakes_the_loop_and_applies_at_the_next_tick():
    session, events = _session()
    _run_owned(session, "o")
    _cycle(session, 5)
    assert session.estop("the red button").accepted
    assert session._wake.is_set()
    _cycle(session)
    assert session.state == "ESTOPPED" and session.last_estop["ticks"] <= 1
    assert events.of("estop")[0]["source"] == "the red button"


def test_a_flood_of_repeated_commands_does_not_grow_the_tasks_event_log():
    session, events = _session()
    _run_owned(session, "o")
    task = session.task
    for _ in range(3):
        for _ in range(200):
            session.submit(_cmd("pause"))
        _cycle(session)
    session.submit(_cmd("resume"))
    _cycle(session)
    for _ in range(200):
        session.submit(_cmd("stop"))
        session.estop("flood")
    _cycle(session, 2)
    delivered = [e["event"] for e in task.executor.events]
    assert delivered == ["pause", "resume", "estop"]  # stop: the e-stop outranked it
    assert len(events.of("estop")) == 200 and session.last_estop["ticks"] <= 1
