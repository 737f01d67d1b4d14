"""The command channel over real Zenoh on 127.0.0.1, with the session in this process (so a
handler can be wedged or broken on purpose): malformed payloads, internal errors, the e-stop's
own path, overload, liveliness, never another task's result. The long campaigns against a
`serve` subprocess are in tests/test_live_attack.py (slow) and bench/live_attack.py."""

from __future__ import annotations

import json
import re
import threading
import time
from collections.abc import Iterator
from typing import Any

import pytest

from orchestrator.live.channel import INTAKE_SIZE
from orchestrator.live.client import Client, SessionLost
from orchestrator.live.protocol import key
from orchestrator.live.server import serve
from orchestrator.live.session import Session

from .live_attacks import CATEGORIES, attack_malformed, free_port, get_raw, malformed_payloads

REACH = ["target=[0.45, -0.25, 0.55]"]


class InProcess:
    """A session served from a thread of this process."""

    def __init__(self, name: str, **kw: Any) -> None:
        self.name = name
        self.endpoint = f"tcp/127.0.0.1:{free_port()}"
        self.session = Session("pick_place", name, seed=3, **{"speed": 1.0, **kw})
        self.stop = threading.Event()
        self.thread = threading.Thread(
            target=serve, args=(self.session, [self.endpoint]), kwargs={"stop": self.stop}
        )
        self.thread.start()
        self.client = Client(name, [self.endpoint], name="test", find_s=30.0)
        self.raw = self.client.z  # queries with raw payloads go through the same link
        self.client.status()

    def until(self, predicate: Any, timeout: float = 60.0) -> dict:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            status = self.client.status()
            if predicate(status):
                return status
            time.sleep(0.02)
        raise AssertionError(f"not within {timeout} s: {self.client.status()}")

    def ended(self, task: str) -> dict:
        return self.until(lambda s: (s["last_result"] or {}).get("task") == task)["last_result"]

    def close(self) -> None:
        self.stop.set()
        self.thread.join(30)
        self.client.close()


@pytest.fixture(scope="module")
def live() -> Iterator[InProcess]:
    served = InProcess("chan", watchdog_s=1.0)
    yield served
    served.close()


def _command(live: InProcess, payload: bytes, timeout: float = 10.0) -> dict | None:
    return get_raw(live.raw, key(live.name, "command"), payload, timeout)


def test_malformed_payloads_are_refused_by_name_and_status_still_answers(live):
    tally = attack_malformed(live.raw, live.name, malformed_payloads(80, seed=1))
    assert tally.accepted == [] and tally.unanswered == 0
    assert tally.refused == 80 and tally.status_answered == 80
    assert set(tally.by_category) == set(CATEGORIES)
    duplicate = _command(live, b'{"op": "status", "op": "estop"}')
    assert duplicate is not None and not duplicate["accepted"]
    assert duplicate["reason"] == "malformed command: duplicate key 'op': each key may appear once"
    assert live.client.status()["state"] == "IDLE"  # the duplicate `estop` was not executed


def test_a_bug_in_one_commands_handling_is_an_internal_error_and_the_channel_goes_on(
    live, monkeypatch
):
    real = live.session.submit

    def submit(cmd):
        if cmd.op == "pause":
            raise KeyError("bug")
        return real(cmd)

    monkeypatch.setattr(live.session, "submit", submit)
    reply = live.client.pause()
    assert not reply.accepted and reply.reason == "internal error: KeyError: 'bug'"
    assert live.client.command("status").status["state"] == "IDLE"


def test_an_estop_is_applied_within_a_tick_while_the_command_handler_is_wedged(live, monkeypatch):
    wedge = threading.Event()
    real = live.session.submit

    def submit(cmd):
        if cmd.op == "pause":
            wedge.wait(60)  # the handler hangs
        return real(cmd)

    monkeypatch.setattr(live.session, "submit", submit)
    reply, _ = live.client.run("reach", REACH)
    assert reply.accepted
    live.until(lambda s: s["state"] == "MOVING")
    try:
        assert _command(live, b'{"op": "pause"}', timeout=0.3) is None  # wedged
        assert _command(live, b'{"op": "status"}', timeout=0.3) is None  # and blocking
        estop = live.client.estop()
        assert estop.accepted
        status = live.until(lambda s: s["state"] == "ESTOPPED", timeout=2.0)
        assert status["last_estop"]["ticks"] <= 1
    finally:
        wedge.set()
    result = live.ended(reply.task)
    assert result["outcome"] == "aborted" and result["reason"]["guard"] == "estop"
    assert live.client.reset().accepted
    live.until(lambda s: s["state"] == "IDLE")


def test_a_put_on_the_estop_key_estops_whatever_its_payload(live):
    live.raw.put(key(live.name, "estop"), b"\xff\x00 not even JSON")
    status = live.until(lambda s: s["state"] == "ESTOPPED", timeout=2.0)
    assert status["last_estop"]["ticks"] <= 1
    assert live.client.reset().accepted
    live.until(lambda s: s["state"] == "IDLE")


def test_an_overflowing_intake_is_refused_as_overloaded_and_every_query_answered(live, monkeypatch):
    wedge = threading.Event()
    real = live.session.submit

    def submit(cmd):
        if cmd.op == "pause":
            wedge.wait(60)
        return real(cmd)

    monkeypatch.setattr(live.session, "submit", submit)
    cmd_key = key(live.name, "command")
    first = live.raw.get(cmd_key, payload=b'{"op": "pause"}', timeout=60)
    time.sleep(0.2)  # the worker holds it
    n = INTAKE_SIZE + 100
    handles = [live.raw.get(cmd_key, payload=b'{"op": "status"}', timeout=60) for _ in range(n)]
    time.sleep(0.5)
    wedge.set()
    replies = [json.loads(r.ok.payload.to_string()) for h in [first, *handles] for r in h if r.ok]
    assert len(replies) == n + 1
    overloaded = [r for r in replies if r["reason"].startswith("overloaded:")]
    assert len(overloaded) >= 100 - 1
    assert sum(r["accepted"] for r in replies) >= INTAKE_SIZE - 1


def test_the_thread_count_stays_flat_under_a_flood(live):
    import psutil

    proc = psutil.Process()
    cmd_key = key(live.name, "command")
    for _ in range(2):  # warm: Zenoh's pools
        list(live.raw.get(cmd_key, payload=b'{"op": "status"}', timeout=10))
    before = proc.num_threads()
    payloads = [b'{"op": "status"}', b'{"op": "run", "machine": "home"}', b"\xff", b"[]"]
    handles = [live.raw.get(cmd_key, payload=payloads[i % 4], timeout=60) for i in range(2000)]
    answered = sum(1 for h in handles for r in h if r.ok is not None)
    after = proc.num_threads()
    assert answered == 2000 and after - before <= 2, (before, after)
    live.until(lambda s: s["task"] is None and s["state"] in ("IDLE", "ERROR"))
    if live.client.status()["state"] == "ERROR":  # the flood's own `run`: nobody supervised it
        assert live.client.reset().accepted


def test_a_waiting_client_never_takes_another_tasks_result(live):
    got: dict[str, Any] = {}

    def wait() -> None:
        try:
            got["reply"], got["result"] = live.client.run("pick_place", wait=True)  # ~5 s
        except Exception as exc:  # shown by the assertion below
            got["error"] = exc

    waiter = threading.Thread(target=wait)
    waiter.start()
    mine = live.until(lambda s: s["task"] is not None)["task"]["id"]
    epoch, n = mine.rsplit("-", 1)
    forged = {"event": "task_end", "result": {"outcome": "succeeded", "exit_code": 0}}
    other_epoch = ("1" if epoch[0] == "0" else "0") + epoch[1:]
    for other in (f"{other_epoch}-{n}", f"{epoch}-{int(n) + 1}", int(n), n):
        live.raw.put(key(live.name, "events"), json.dumps({**forged, "task": other}))
    time.sleep(0.3)
    assert waiter.is_alive(), got  # none of them is its task
    waiter.join(60)
    assert got["reply"].task == mine and got["result"]["task"] == mine
    assert got["result"]["outcome"] == "succeeded" and "metrics" in got["result"]


def test_a_client_waiting_on_a_task_fails_fast_when_the_session_goes():
    served = InProcess("gone", watchdog_s=1.0)
    caught: dict[str, Any] = {}

    def wait() -> None:
        try:
            served.client.run("reach", REACH, wait=True)
        except SessionLost as exc:
            caught["exc"], caught["t"] = exc, time.monotonic()

    waiter = threading.Thread(target=wait)
    waiter.start()
    try:
        served.until(lambda s: s["state"] == "MOVING")
        served.session.publish = lambda leaf, msg: None  # a crash: no `shutdown` event
        t0 = time.monotonic()
        served.stop.set()  # the session ends without ending the task
        served.thread.join(30)
        waiter.join(10)
        assert "exc" in caught and caught["t"] - t0 < 2.0  # ms unloaded; bounded for CI
        assert "lost while waiting on task" in str(caught["exc"])
    finally:
        served.close()


def test_send_wait_exits_5_when_the_session_goes_away(cli):
    served = InProcess("gone-cli", watchdog_s=1.0)

    def end_it() -> None:
        served.until(lambda s: s["state"] == "MOVING")
        served.stop.set()

    ender = threading.Thread(target=end_it)
    ender.start()
    try:
        t0 = time.monotonic()
        res = cli("send", served.name, "run", "reach", "--set", REACH[0], "--wait",
                  "--connect", served.endpoint)  # fmt: skip
        assert res.exit_code == 5 and time.monotonic() - t0 < 30
        assert re.match(
            f"error: session '{served.name}' (lost while waiting on|shut down before) task",
            res.stderr,
        ), res.stderr
    finally:
        ender.join(30)
        served.close()


def test_send_run_without_wait_says_the_watchdog_will_stop_its_task(live, cli):
    res = cli("send", live.name, "run", "pick_place", "--connect", live.endpoint)
    assert res.exit_code == 0 and res.stdout.startswith("accepted: task ")
    assert "the session's watchdog stops the task after 1.0 s (use --wait" in res.stderr
    status = live.until(lambda s: s["state"] == "ERROR", timeout=30.0)
    assert status["error"].startswith("watchdog: no heartbeat from task ")
    assert "(orchestrator send)" in status["error"]
    live.until(lambda s: s["task"] is None)
    assert live.client.reset().accepted
