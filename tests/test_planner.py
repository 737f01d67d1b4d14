"""The planner adapter against a local chat-completions server with canned replies: only a
good proposal moves the robot; every bad one is refused before anything moves."""

from __future__ import annotations

import socket
import threading
import time
from collections.abc import Iterator

import numpy as np
import pytest

from orchestrator.live.client import Client
from orchestrator.live.planner import PlannerError, ask_planner, parse_reply
from orchestrator.live.server import serve
from orchestrator.live.session import Session

from . import canned_planner
from .canned_planner import CannedPlanner


def _port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@pytest.fixture(scope="module")
def planner() -> Iterator[str]:
    url, server = canned_planner.start()
    yield url
    server.shutdown()


class _JointMotion:
    """The largest change of any arm joint angle since `start`, over every physics step of
    the session (ground truth, not its log)."""

    def __init__(self, session: Session) -> None:
        self.idx = session.world.arm_qpos
        self.q0 = session.world.data.qpos[self.idx].copy()
        self.max_rad = 0.0
        session.loop.set_observers([self])

    def on_step(self, ctx) -> None:
        self.max_rad = max(self.max_rad, float(np.abs(ctx.data.qpos[self.idx] - self.q0).max()))


@pytest.fixture(scope="module")
def served() -> Iterator[tuple[Session, Client]]:
    endpoint = f"tcp/127.0.0.1:{_port()}"
    session = Session("pick_place", "p", seed=3, speed=0.0)
    stop = threading.Event()
    thread = threading.Thread(target=serve, args=(session, [endpoint], None, None, stop))
    thread.start()
    c = Client("p", [endpoint], name="planner test", find_s=60.0)
    yield session, c
    c.close()
    stop.set()
    thread.join(30)


@pytest.fixture
def client(served) -> Client:
    return served[1]


@pytest.mark.parametrize(
    ("reply", "words"),
    [
        ('{"machine": "reach", "set": {"target": [1.7, 0.0, 0.5]}}', "outside the workspace"),
        ('{"machine": "pick_place", "set": {"object": "red_ball", "place_at": "pad"}}',
         "red_ball"),
        ('{"machine": "reach", "set": {"target": [0.5, 0.1, 0.4]}, "speed": "max"}',
         "speed: Extra inputs are not permitted"),
        ("Sure! I will move the arm to the red cube now.", "did not answer with JSON"),
        ('{"machine": "self_destruct"}', "valid: pick_place, reach, home"),
        ('{"machine": "reach", "set": {"target": [0.5, 0.1, 0.4], "guards": {}}}',
         "`guards` is a scenario value, not an input"),
        ('{"machine": "reach", "set": {"guards.workspace.max": [0.95, 0.7, 1.2]}}',
         "`guards.workspace.max` is a scenario value"),
        ('{"machine": "reach", "set": {"physics.safe_stop.max_decel_rad_s2": 1}}',
         "`physics.safe_stop.max_decel_rad_s2` is a scenario value"),
        ('{"machine": "reach", "set": {"scene.table.height": 0.1}}',
         "`scene.table.height` is a scenario value"),
        ('{"machine": "reach", "set": {"robot.base_pos": [0, 0, 0.1]}}',
         "`robot.base_pos` is a scenario value"),
        ('{"machine": "pick_place", "set": {"hover": [0, 0, 5]}}',
         "`hover` is not an input of machine 'pick_place'"),
        ('{"machine": "reach", "set": {"target": [NaN, 0, 0.4]}}', "NaN: not finite"),
        ('{"machine": "reach", "set": {"target": [1e400, 0, 0.4]}}', "1e400: not finite"),
    ],
)  # fmt: skip
def test_a_bad_proposal_never_moves_the_robot(planner, served, monkeypatch, reply, words):
    session, client = served
    monkeypatch.setenv("ORCHESTRATOR_PLANNER_URL", planner)
    CannedPlanner.reply = reply
    before = client.status()
    motion = _JointMotion(session)
    try:
        _, answer, _ = ask_planner(client, "put the red cube on the pad")
        assert not answer.accepted and words in answer.reason, answer.reason
    except PlannerError as exc:
        assert words in str(exc)
    time.sleep(0.2)  # 20 control ticks at least: whatever was applied has moved the arm
    after = client.status()
    assert after["state"] == "IDLE" and after["last_result"] == before["last_result"]
    assert motion.max_rad < 1e-5  # the hold's own settling: micro-radians


def test_a_good_proposal_runs_through_the_guardrails(planner, client, monkeypatch):
    monkeypatch.setenv("ORCHESTRATOR_PLANNER_URL", planner)
    CannedPlanner.reply = (
        '```json\n{"machine": "pick_place", "set": {"object": "cube", "place_at": "pad"}}\n```'
    )
    CannedPlanner.requests.clear()
    proposal, answer, result = ask_planner(client, "put the red cube on the pad", wait=True)
    assert answer.accepted and proposal["machine"] == "pick_place"
    assert result is not None and result["outcome"] == "succeeded"
    prompt = CannedPlanner.requests[0]["messages"][0]["content"]
    assert "Scene objects: cube." in prompt and "Markers: pad." in prompt
    assert '"additionalProperties": false' in prompt  # the schema it must answer with


def test_parse_reply_refuses_a_list():
    with pytest.raises(PlannerError, match="invalid"):
        parse_reply("[1, 2, 3]")


def test_ask_without_a_planner_says_so(cli, monkeypatch):
    monkeypatch.delenv("ORCHESTRATOR_PLANNER_URL", raising=False)
    res = cli("ask", "nobody", "put the cube on the pad")
    assert res.exit_code == 2 and "no planner configured" in res.stderr
