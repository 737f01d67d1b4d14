"""Visible, safe recovery: a world that violates a guard before a task starts is BLOCKED (named
in the status), and `recover` backs the arm out with every guard active, a violated one allowed
only to shrink (guards/easing.py)."""

from __future__ import annotations

import re
from collections.abc import Iterator

import numpy as np
import pytest

from orchestrator.guards.easing import Eased
from orchestrator.guards.sensor_health import SensorHealth, SensorHealthParams
from orchestrator.guards.workspace import Workspace, WorkspaceParams
from orchestrator.language.load import load_scenario
from orchestrator.live.protocol import Command
from orchestrator.live.session import Session
from orchestrator.live.task import Task

from .test_hint import world_context

# -- the guard layer ------------------------------------------------------------------------


@pytest.fixture(scope="module")
def ctx():
    return world_context("pick_place")


def _box_around_tcp(ctx, dx: float) -> Eased:
    """A workspace guard whose max x is `dx` below the TCP's x (the TCP `dx` past it)."""
    x, y, z = ctx.tcp_pos.tolist()
    params = WorkspaceParams(min=[x - 0.5, y - 0.5, z - 0.5], max=[x - dx, y + 0.5, z + 0.5])
    guard = Workspace(params)
    guard.bind(ctx)
    eased = Eased(guard)
    eased.activate(ctx)
    return eased


@pytest.fixture
def tcp(ctx) -> Iterator[np.ndarray]:
    """The TCP position MuJoCo computed, written by the test (restored after it)."""
    view = ctx.data.site_xpos[ctx.world.tcp_site]
    saved = view.copy()
    yield view
    view[:] = saved


def test_a_violated_guard_may_only_shrink_while_recovering(ctx, tcp):
    guard = _box_around_tcp(ctx, 0.010)  # 10 mm past max x
    assert guard.eased and guard.envelope(ctx) is None  # checked in full every step
    tcp[0] -= 0.004  # 6 mm past: shrinking
    assert guard.check(ctx) is None
    tcp[0] += 0.0009  # 6.9 mm: grew by less than the 1 mm tolerance from the least (6 mm)
    assert guard.check(ctx) is None
    tcp[0] += 0.0002  # 7.1 mm: 1.1 mm beyond the least it reached
    violation = guard.check(ctx)
    assert violation is not None and violation.guard == "workspace"
    assert violation.message.endswith(
        "(grew while recovering: 0.0071 m past its limit, the least it had reached was 0.006 m "
        "(tolerance 0.001 m))"
    )


def test_a_limit_within_on_entry_may_not_be_crossed_while_recovering(ctx, tcp):
    guard = _box_around_tcp(ctx, 0.010)
    tcp[2] += 0.6  # z past its max, which it was within on entry
    violation = guard.check(ctx)
    assert violation is not None and violation.message.endswith(
        "(a new violation while recovering)"
    )


def test_back_within_its_limits_a_guard_is_checked_as_usual(ctx, tcp):
    guard = _box_around_tcp(ctx, 0.010)
    tcp[0] -= 0.011  # inside again
    assert guard.check(ctx) is None and not guard.eased
    tcp[0] += 0.0105  # 0.5 mm past max x: fires as usual, no tolerance any more
    violation = guard.check(ctx)
    assert violation is not None and "recovering" not in violation.message


def test_a_guard_within_on_entry_is_not_eased(ctx, tcp):
    guard = _box_around_tcp(ctx, -0.010)  # 10 mm inside
    assert not guard.eased and guard.envelope(ctx) is not None
    tcp[0] += 0.0101
    assert guard.check(ctx) is not None


def test_a_guard_that_cannot_measure_its_violation_is_checked_as_usual(ctx):
    guard = SensorHealth(SensorHealthParams())
    guard.bind(ctx)
    assert guard.excess(ctx) is None
    eased = Eased(guard)
    eased.activate(ctx)
    assert not eased.eased  # a sensor fault is not moved away from: it fires as usual


# -- sessions -------------------------------------------------------------------------------


def _session(events: list[dict]) -> Session:
    return Session(
        "pick_place",
        "recovery",
        seed=3,
        speed=0.0,
        publish=lambda leaf, msg: events.append(msg) if leaf == "events" else None,
    )


def _step(session: Session, watch=None) -> None:
    """The session's loop without the transport and the pacing, until it idles."""
    for _ in range(5000):
        session._drain()
        if session.task is None and session.tasks and not session.estopped:
            session._start_next()
        if watch is not None and session.task is not None:
            watch(session.task)
        session._tick()
        session._after_tick()
        if session.task is None and not session.tasks:
            return
    raise AssertionError("the session never became idle")


def _stuck(session: Session, case: str) -> None:
    """Leave the arm where a guard is violated, the way an abort or a widened limit did
    before (a task started locally, past the channel's rules)."""
    cube = session.ctx.object_pose("cube").pos
    if case == "hand on the cube":  # no guards: the hand pushed down onto the cube
        sets = ["guards={}", f"target=[{cube[0]}, {cube[1]}, 0.21]"]
    else:  # a widened workspace let the TCP out to y = 0.62
        # (x 0.35: at x 0.45 the move's dry run finds the pose out of the IK's reach)
        sets = ["guards.workspace.max=[0.95, 0.7, 1.2]", "target=[0.35, 0.62, 0.4]"]
    loaded = load_scenario("pick_place", sets, machine="reach")
    session.tasks.append(Task(100, loaded, session.cell, "reach"))
    _step(session)
    for _ in range(10):
        session._tick()
        session._after_tick()


CASES = [
    ("hand on the cube", "collision", re.escape("robot contact with panda_hand ~ cube_geom")),
    pytest.param(
        "TCP outside the workspace",
        "workspace",
        # the move ends within its tolerance of y = 0.62 (0.6198 since the controller's model
        # knows the rotor inertia): the message names a y within a millimetre of it
        r"TCP y = 0\.(619|620|621)\d m is outside the workspace",
        marks=pytest.mark.slow,
    ),
]


@pytest.mark.parametrize(("case", "guard", "message"), CASES)
def test_a_stuck_arm_is_blocked_and_recovers_with_every_guard_active(case, guard, message):
    events: list[dict] = []
    session = _session(events)
    _stuck(session, case)
    status = session.status()
    assert status["state"] == "BLOCKED"
    assert status["blocked"]["guard"] == guard and re.match(message, status["blocked"]["message"])
    assert status["blocked"]["recoverable"] is True
    refused = session.submit(Command(op="run", machine="home"))
    assert not refused.accepted and re.match(
        f"the robot is BLOCKED: {guard}: {message}", refused.reason
    )
    assert refused.reason.endswith(
        "send `recover` first (it backs the arm out, every guard active)"
    )

    active: set[str] = set()
    eased: set[str] = set()

    def watch(task: Task) -> None:
        ex = task.executor
        if ex is not None and not ex.done and ex.violation is None:
            active.update(g.name for g in ex.active_guards)
            eased.update(g.name for g in ex.active_guards if isinstance(g, Eased) and g.eased)

    reply = session.submit(Command(op="recover", client="test"))
    assert reply.accepted, reply.reason
    _step(session, watch)
    result = session.last_result
    assert result["machine"] == "recover" and result["outcome"] == "succeeded", result
    assert [t["to"] for t in result["transitions"]] == ["BACK_OFF", "VERIFY", "DONE"]
    scenario_guards = set(session.loaded.scenario.guards)  # type: ignore[arg-type]
    assert (
        scenario_guards <= active and guard in eased
    )  # every guard active; the one violated eased
    assert session.state == "IDLE" and session.status()["blocked"] is None

    assert session.submit(Command(op="run", machine="home")).accepted
    _step(session)
    assert session.last_result["machine"] == "home"
    assert session.last_result["outcome"] == "succeeded"
    states = [(e["from"], e["to"]) for e in events if e["event"] == "state"]
    assert states == [
        ("IDLE", "MOVING"), ("MOVING", "BLOCKED"), ("BLOCKED", "MOVING"), ("MOVING", "IDLE"),
        ("IDLE", "MOVING"), ("MOVING", "IDLE"),
    ]  # fmt: skip
    blocked = next(e for e in events if e["event"] == "state" and e["to"] == "BLOCKED")
    assert blocked["blocked"]["guard"] == guard


PAST_THE_STOP = """name: past_the_stop
initial: TURN
states:
  TURN:
    skill: move_joints
    with: {to: [-0.222, -1.85, -0.308, -2.761, -0.022, 1.636, 1.674]}
    transitions: {reached: DONE, timeout: DONE}
  DONE: {final: succeeded}
"""
"""Shoulder (panda_joint2) 87 mrad past its lower limit (-1.7628 rad), the TCP inside the
workspace and clear of the table: the arm comes to rest on the joint's stop."""


def test_a_joint_stopped_past_its_range_is_turned_back_by_recover(tmp_path):
    """Found by the live protocol's model test (tests/test_live_model.py): after a random
    interleaving a pick's controlled stop left panda_joint2 2.5 mrad past its range; BLOCKED
    (`joint_limits`, recoverable), but `recover` looked only at contacts and the workspace,
    ended `succeeded` at once, and the session stayed BLOCKED for good."""
    events: list[dict] = []
    session = _session(events)
    (tmp_path / "past_the_stop.yaml").write_text(PAST_THE_STOP)
    loaded = load_scenario("pick_place", machine=str(tmp_path / "past_the_stop.yaml"),
                           allow_paths=[tmp_path])  # fmt: skip
    session.tasks.append(Task(100, loaded, session.cell, "past_the_stop"))
    _step(session)  # a task started locally, past the channel's rules
    for _ in range(10):
        session._tick()
        session._after_tick()
    blocked = session.status()["blocked"]
    assert session.state == "BLOCKED", session.status()
    assert blocked["guard"] == "joint_limits" and blocked["recoverable"] is True
    assert blocked["message"].startswith("panda_joint2 at")

    assert session.submit(Command(op="recover", client="test")).accepted
    _step(session)
    for _ in range(10):  # the idle world's guards, after the recovery
        session._tick()
        session._after_tick()
    result = session.last_result
    assert result["machine"] == "recover" and result["outcome"] == "succeeded", result
    assert [t["to"] for t in result["transitions"]] == ["UNWIND", "VERIFY_JOINTS", "DONE"]
    assert session.state == "IDLE" and session.status()["blocked"] is None
    model = session.world.model
    lower = float(model.jnt_range[model.joint("panda_joint2").id, 0])
    q2 = float(session.world.data.qpos[session.world.arm_qpos][1])
    assert lower + 0.015 < q2 < lower + 0.025  # turned back 0.02 rad inside its range
    assert session.submit(Command(op="run", machine="home")).accepted
    _step(session)
    assert session.last_result["outcome"] == "succeeded"


WRONG_WAY = """name: wrong_way
recovery: true
initial: OUT
states:
  OUT:
    skill: move
    with: {target: [0.35, 0.64, 0.4], orientation: keep, max_speed: 0.05}
    transitions: {reached: DONE, unreachable: DONE, timeout: DONE}
  DONE: {final: succeeded}
"""


@pytest.mark.slow
def test_a_recovery_that_moves_further_out_is_aborted(tmp_path):
    session = _session([])
    _stuck(session, "TCP outside the workspace")
    (tmp_path / "wrong_way.yaml").write_text(WRONG_WAY)
    session.allow_paths = (tmp_path,)
    reply = session.submit(Command(op="run", machine=str(tmp_path / "wrong_way.yaml")))
    assert reply.accepted, reply.reason
    _step(session)
    result = session.last_result
    assert result["outcome"] == "aborted" and result["reason"]["guard"] == "workspace"
    assert "grew while recovering" in result["reason"]["message"]
    y = session.ctx.tcp_pos[1]
    assert y < 0.6225  # stopped within ~2 mm of where it started (0.6200)
    assert session.state == "BLOCKED"


def test_recover_runs_with_orchestrator_run_where_the_scenario_starts_outside(cli):
    """A workspace whose top is below the home TCP (z 0.487): a machine that moves aborts on
    its first step; `recover` brings the TCP down into the box, every guard active."""
    box = "guards.workspace.max=[0.95, 0.6, 0.45]"
    reach = ("machine=reach", "target=[0.45, 0.1, 0.4]")
    res = cli("run", "pick_place", "--set", reach[0], "--set", reach[1], "--set", box, "--json")
    assert res.exit_code == 3 and '"guard": "workspace"' in res.stdout
    assert '"abort_t": 0.002' in res.stdout
    res = cli("run", "pick_place", "--set", "machine=recover", "--set", box, "--json")
    assert res.exit_code == 0, res.stdout + res.stderr
    assert '"to": "BACK_OFF"' in res.stdout and '"to": "DONE"' in res.stdout


def test_recover_takes_no_values(cli):
    session = _session([])
    reply = session.submit(Command(op="recover", set=["speed=1.0"]))
    assert not reply.accepted and reply.reason == "recover: takes no machine and no values"
    res = cli("send", "nobody", "recover", "--set", "speed=1")
    assert res.exit_code == 2 and "recover: takes no MACHINE and no --set" in res.stderr


def test_recover_is_refused_for_a_violation_moving_cannot_undo():
    from orchestrator.guards.base import Violation

    session = _session([])
    session.blocked.violation = Violation(
        "sensor_health", "wrist force sensor reads a non-finite value", None, None
    )
    session.blocked.recoverable = False
    assert session.state == "BLOCKED"
    reply = session.submit(Command(op="recover"))
    assert not reply.accepted and reply.reason == (
        "the robot is BLOCKED: sensor_health: wrist force sensor reads a non-finite value: "
        "moving the arm cannot undo this (a fault, not a place); find its cause and restart the "
        "session"
    )


def test_watch_shows_what_blocks_the_arm():
    from rich.console import Console

    from orchestrator.live.watch import render

    status = {
        "state": "BLOCKED", "task": None, "queued": 0, "last_result": None, "error": None,
        "sim_time": 1.0, "wall_time": 1.0, "realtime_factor": None, "tcp": [0.443, 0.61, 0.39],
        "blocked": {"guard": "workspace", "message": "TCP y = 0.6100 m is outside the "
                    "workspace [-0.600, 0.600]", "value": None, "limit": None,
                    "recoverable": True},
    }  # fmt: skip
    console = Console(record=True, width=200)
    console.print(render(status, 0.1, "cell1"))
    text = console.export_text()
    assert "BLOCKED" in text
    assert (
        "workspace: TCP y = 0.6100 m is outside the workspace [-0.600, 0.600] (send recover)"
        in text
    )
