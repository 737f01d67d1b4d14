"""The restore race of issue 39, against a real `serve` on 127.0.0.1: a `restore` is read
while an e-stop lands; the e-stop must hold (no `reset` was sent) and the arm must stay still,
judged by the arm's peak joint speed on every physics step (the status's `arm_speed`)."""

from __future__ import annotations

import threading
import time

import pytest

from orchestrator.engine.snapshot.signing import KEY_ENV
from orchestrator.live.client import Client

from .live_server import LiveServer, motion_while_latched


@pytest.fixture(autouse=True)
def _own_key(tmp_path, monkeypatch):
    monkeypatch.delenv(KEY_ENV, raising=False)
    monkeypatch.setenv("XDG_CONFIG_HOME", str(tmp_path / "config"))


@pytest.fixture
def server(tmp_path):
    srv = LiveServer(tmp_path, name="latch")
    yield srv
    srv.close()


def _snapshot_mid_task(srv: LiveServer, client: Client) -> None:
    """A pick under way, a snapshot of it written, then the task stopped (IDLE again)."""
    reply, _ = client.run()
    assert reply.accepted, reply.reason
    srv.wait_status(lambda s: s["state"] in ("MOVING", "GRASPING"), 60.0)
    time.sleep(0.5)
    assert client.command("snapshot", snapshot="mid").accepted
    deadline = time.monotonic() + 60.0
    while not any(e["event"] == "snapshot" for e in srv.snapshot_events()[0]):
        assert time.monotonic() < deadline, "the snapshot was never written"
        time.sleep(0.05)
    stopped = client.stop()  # on a loaded host the pick may have ended while it was written
    assert stopped.accepted or stopped.reason.startswith("no task is running"), stopped.reason
    srv.wait_status(lambda s: s["state"] == "IDLE", 60.0)


def test_an_estop_during_a_restore_holds_and_the_arm_stays_still(server):
    with (
        Client(server.name, [server.endpoint], name="restorer") as restorer,
        Client(server.name, [server.endpoint], name="guard") as guard,
    ):
        _snapshot_mid_task(server, restorer)
        replies: dict[str, object] = {}
        # the restore is read (~0.1 s) before it is queued; the e-stop lands in that window
        sender = threading.Thread(
            target=lambda: replies.update(restore=restorer.command("restore", snapshot="mid"))
        )
        sender.start()
        time.sleep(0.02)
        assert guard.estop().accepted
        sender.join(30.0)
        status = server.wait_status(lambda s: s["state"] == "ESTOPPED", 10.0)
        stop_t = status["last_estop"]["t"]
        time.sleep(2.0)  # two seconds latched: nobody sends `reset`
        events, statuses = server.snapshot_events()
    after = statuses[statuses.index(status) :]
    assert {s["state"] for s in after} == {"ESTOPPED"}, [s["state"] for s in after]
    assert not motion_while_latched(after, stop_t), [s["arm_speed"] for s in after]
    assert after[-1]["arm_speed"]["t0"] >= stop_t + 1.0  # the windows do cover the latch
    names = [e["event"] for e in events]
    estop_at = names.index("estop")
    # the restore was either applied before the e-stop (which then stopped it) or refused
    # when applied, after it: never applied after the e-stop
    restored_after = [e for e in events[estop_at:] if e["event"] == "restore"]
    assert not restored_after, restored_after
    refused = [e for e in events[estop_at:] if e["event"] == "refused" and e["op"] == "restore"]
    if replies["restore"].accepted:  # type: ignore[attr-defined]
        assert refused or "restore" in names[:estop_at]
