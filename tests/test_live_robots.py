"""Live sessions on the other arms (issue 44): `serve` of pick_place_ur5 and pick_place_so101
on 127.0.0.1 (Zenoh scouting off, an explicit tcp endpoint) runs a task, an e-stop lands while
the arm moves, and the arm stays still, judged per physics step (the status's
`arm_speed`, its peak joint speed over every step since the previous status), not by the log.
The slow variant first runs a pick to its end (succeeded), then e-stops the next.

The session is tests/live_server.py's (the Panda's pick_place there), built on the scenario
under test.
"""

from __future__ import annotations

import math

import pytest

from orchestrator.engine.snapshot.signing import KEY_ENV
from orchestrator.live.client import Client
from orchestrator.live.session import Session

from . import live_server
from .live_server import SETTLE_S, LiveServer, motion_while_latched

LATCHED_S = 1.0
"""Simulated time the e-stop is watched for, after its grace (`SETTLE_S`) [s]."""


@pytest.fixture(autouse=True)
def _own_key(tmp_path, monkeypatch):
    monkeypatch.delenv(KEY_ENV, raising=False)
    monkeypatch.setenv("XDG_CONFIG_HOME", str(tmp_path / "config"))


def _serve(tmp_path, monkeypatch, scenario: str) -> LiveServer:
    """tests/live_server.py's server, its session built on `scenario`."""
    monkeypatch.setattr(
        live_server, "Session", lambda _panda, *args, **kw: Session(scenario, *args, **kw)
    )
    return LiveServer(tmp_path, name=scenario.replace("_", "-"), seed=1, speed=0.0)


def _peak(status: dict) -> float:
    """The arm's peak joint speed over the status's window [rad/s] (0 without one)."""
    speed = status.get("arm_speed") or {}
    return float(speed.get("peak") or 0.0)


def _estop_while_moving(srv: LiveServer, client: Client) -> list[dict]:
    """Start a task, e-stop it while the arm moves, watch the latch for `LATCHED_S` after the
    grace: the statuses from the e-stop's on, and the e-stop's simulated time."""
    reply, _ = client.run()
    assert reply.accepted, reply.reason
    srv.wait_status(lambda s: s["state"] == "MOVING" and _peak(s) > 0.05, 60.0)
    assert client.estop().accepted
    status = srv.wait_status(lambda s: s["state"] == "ESTOPPED", 30.0)
    stop_t = status["last_estop"]["t"]
    srv.wait_status(lambda s: _t0(s) >= stop_t + SETTLE_S + LATCHED_S, 60.0)
    _, statuses = srv.snapshot_events()
    after = statuses[statuses.index(status) :]
    assert {s["state"] for s in after} == {"ESTOPPED"}, [s["state"] for s in after]
    assert not motion_while_latched(after, stop_t), [s["arm_speed"] for s in after]
    return after


def _t0(status: dict) -> float:
    """Where the status's window starts [s of simulated time] (-inf without one)."""
    speed = status.get("arm_speed") or {}
    return -math.inf if speed.get("t0") is None else float(speed["t0"])


@pytest.mark.parametrize("scenario", ["pick_place_ur5", "pick_place_so101"])
def test_a_live_session_on_another_arm_estops_a_task_and_the_arm_stays_still(
    tmp_path, monkeypatch, scenario
):
    srv = _serve(tmp_path, monkeypatch, scenario)
    try:
        with Client(srv.name, [srv.endpoint], name="operator") as client:
            _estop_while_moving(srv, client)
    finally:
        srv.close()


@pytest.mark.slow
@pytest.mark.parametrize("scenario", ["pick_place_ur5", "pick_place_so101"])
def test_a_live_session_on_another_arm_finishes_a_pick_then_an_estop_holds_the_next(
    tmp_path, monkeypatch, scenario
):
    srv = _serve(tmp_path, monkeypatch, scenario)
    try:
        with Client(srv.name, [srv.endpoint], name="operator") as client:
            reply, end = client.run(wait=True)
            assert reply.accepted, reply.reason
            assert end is not None and end["outcome"] == "succeeded", end
            _estop_while_moving(srv, client)
    finally:
        srv.close()
