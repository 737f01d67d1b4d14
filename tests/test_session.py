"""The session's command handling, stepped by hand (no transport, no thread)."""

from __future__ import annotations

import pytest

from orchestrator.live.protocol import Command
from orchestrator.live.session import Session


@pytest.fixture
def session() -> Session:
    return Session("pick_place", "s", seed=3, speed=0.0)


def _cmd(op: str, **kw) -> Command:
    return Command(op=op, **kw)  # type: ignore[arg-type]


def test_a_run_sent_right_after_a_reset_is_accepted(session):
    assert session.submit(_cmd("estop")).accepted
    session._drain()
    assert session.state == "ESTOPPED"
    assert not session.submit(_cmd("run", machine="home")).accepted  # no reset yet
    assert session.submit(_cmd("reset")).accepted
    reply = session.submit(_cmd("run", machine="home"))  # before the reset took effect
    assert reply.accepted and reply.task is not None
    session._drain()
    assert session.state == "IDLE" and [t.id for t in session.tasks] == [reply.task]


def test_an_estop_voids_a_reset_sent_before_it_in_the_same_tick(session):
    session.submit(_cmd("estop"))
    session._drain()
    session.submit(_cmd("reset"))
    session.submit(_cmd("estop"))
    session._drain()
    assert session.state == "ESTOPPED"


def test_commands_in_one_tick_apply_by_priority_and_the_estop_latency_is_recorded(session):
    session.submit(_cmd("run", machine="reach", set=["target=[0.5, 0.1, 0.4]"]))
    session._drain()
    session.task = session.tasks.popleft()
    session.task.start()
    session._tick()
    session.submit(_cmd("pause"))
    session.submit(_cmd("estop"))  # sent after the pause, applied first
    session._drain()
    assert session.state == "ESTOPPED" and session.last_estop["ticks"] <= 1
    events = [e["event"] for e in session.task.executor.events]
    assert events[0] == "estop"  # the pause came after it and changed nothing


def test_every_task_can_be_recorded(tmp_path):
    import threading
    import time

    from orchestrator.recording import RerunRecorder

    paths = []

    def recorder(task):
        paths.append(tmp_path / f"task-{task.id}.rrd")
        return RerunRecorder(path=paths[-1])

    session = Session("pick_place", "r", seed=3, speed=0.0, recorder=recorder)
    stop = threading.Event()
    thread = threading.Thread(target=session.run, args=(stop,))
    thread.start()
    try:
        reply = session.submit(_cmd("run", machine="reach", set=["target=[0.5, 0.1, 0.4]"]))
        deadline = time.monotonic() + 120
        while (session.last_result or {}).get("task") != reply.task:
            assert time.monotonic() < deadline
            time.sleep(0.05)
    finally:
        stop.set()
        thread.join(30)
    assert session.last_result["outcome"] == "succeeded"
    assert len(paths) == 1 and paths[0].stat().st_size > 10_000


def test_run_guards_a_goal_set_on_the_command_line(cli):
    res = cli("run", "pick_place", "--set", "place_at=[1.2, 0.2, 0.3]")
    assert res.exit_code == 2 and "goal rejected: place_at" in res.stderr
    assert "outside the workspace" in res.stderr and "Traceback" not in res.stderr


def test_serve_a_broken_scenario_exits_2_before_opening_anything(cli):
    res = cli("serve", "no_such_scenario", "--session", "x")
    assert res.exit_code == 2 and "no such scenario" in res.stderr


def test_stop_is_the_machines_own_stop_event_when_it_declares_one(session, tmp_path):
    machine = tmp_path / "cell.yaml"
    machine.write_text(
        "name: cell\ninitial: WORK\nevents: {stop: GO_HOME}\nstates:\n"
        "  WORK:\n    skill: move\n    with: {target: [0.45, -0.25, 0.55]}\n"
        "    transitions: {reached: DONE, unreachable: FAILED, timeout: FAILED}\n"
        "  GO_HOME:\n    skill: move_joints\n    with: {to: home}\n"
        "    transitions: {reached: STOPPED, timeout: FAILED}\n"
        "  DONE: {final: succeeded}\n  STOPPED: {final: failed}\n  FAILED: {final: failed}\n"
    )
    refused = session.submit(_cmd("run", machine=str(machine)))
    assert not refused.accepted and "--allow-path" in refused.reason  # outside the tree
    session.allow_paths = (tmp_path,)
    reply = session.submit(_cmd("run", machine=str(machine)))
    assert reply.accepted, reply.reason
    session._drain()
    session.task = session.tasks.popleft()
    session.task.start()
    for _ in range(30):
        session._tick()
    assert session.submit(_cmd("stop")).accepted
    session._drain()
    for _ in range(1000):
        if session.last_result is not None:
            break
        session._tick()
    result = session.last_result
    assert result["final_state"] == "STOPPED" and result["metrics"]["stopped_by"] == "stop command"
    assert [t["trigger"] for t in result["transitions"]][-2:] == ["stop", "reached"]
