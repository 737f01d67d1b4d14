"""The attack suite's long part (issue 26), against `orchestrator serve` subprocesses on
127.0.0.1: the campaigns of bench/live_attack.py with their acceptance bounds asserted.
The fast part is tests/test_live_channel.py, tests/test_wire.py and tests/test_access.py."""

from __future__ import annotations

import time

import pytest

from orchestrator.live.access import MAX_MESSAGE_BYTES
from orchestrator.live.client import EXIT_SESSION_LOST

from .live_attacks import (
    CATEGORIES,
    Served,
    attack_malformed,
    bystander,
    flood,
    get_raw,
    hold_paused_task,
    kill_mid_wait,
    malformed_payloads,
    wait_for,
)

pytestmark = pytest.mark.slow


def test_1000_malformed_payloads_are_refused_and_each_is_followed_by_a_status_that_answers():
    served = Served("slow-malformed", "--watchdog", "0")
    try:
        z = served.raw()
        tally = attack_malformed(z, served.name, malformed_payloads(1000, seed=3))
        z.close()
        assert tally.accepted == [] and tally.unanswered == 0
        assert tally.refused == 1000 and tally.status_answered == 1000
        assert set(tally.by_category) == set(CATEGORIES)
        assert served.client.status()["state"] == "IDLE"
    finally:
        served.close()


def test_a_payload_over_zenohs_message_limit_is_dropped_and_the_session_goes_on():
    served = Served("slow-limit", "--watchdog", "0")
    try:
        z = served.raw()
        command = f"orchestrator/{served.name}/command"
        assert get_raw(z, command, b"x" * (MAX_MESSAGE_BYTES + 1), timeout=3.0) is None
        assert get_raw(z, command, b"x" * 50_000_000)["reason"] == (
            "malformed command: too large: 50000000 bytes (limit 65536)"
        )  # under the limit (headers need room too): answered
        assert get_raw(z, command, b'{"op": "status"}')["status"]["state"] == "IDLE"
        z.close()
    finally:
        served.close()


def test_an_estop_behind_a_flood_is_applied_within_one_control_tick():
    served = Served("slow-estop", "--speed", "1", "--watchdog", "0")
    try:
        z = served.raw()
        c = served.client
        reply, _ = c.run("pick_place")
        wait_for(lambda: c.status()["state"] in ("MOVING", "GRASPING"), 60.0)
        time.sleep(1.0)
        handles = [z.get(f"orchestrator/{served.name}/command", payload=b'{"op": "status"}',
                         timeout=60) for _ in range(2000)]  # fmt: skip
        assert c.estop().accepted
        status = wait_for(
            lambda: (s := c.status())["last_result"] and s["last_result"]["task"] == reply.task
            and s, 60.0,
        )  # fmt: skip
        assert status["last_estop"]["ticks"] <= 1
        assert status["last_result"]["reason"]["guard"] == "estop"
        assert sum(1 for h in handles for r in h if r.ok is not None) == 2000
        z.close()
    finally:
        served.close()


def test_a_10000_command_flood_is_answered_in_full_with_flat_memory_and_threads():
    served = Served("slow-flood", "--watchdog", "0")
    try:
        z = served.raw()
        hold_paused_task(served)  # busy and frozen: what grows is the channel's
        flood(z, served.name, 1000, seed=99)
        rss0, threads0 = served.rss_mb(), served.threads()
        counts = flood(z, served.name, 10_000)
        rss1, threads1 = served.rss_mb(), served.threads()
        z.close()
        assert counts.get("unanswered", 0) == 0 and sum(counts.values()) == 10_000
        assert rss1 - rss0 <= 20.0, (rss0, rss1)
        assert threads1 == threads0
    finally:
        served.close()


def test_a_killed_server_makes_the_waiting_client_exit_5_and_a_restart_reuses_no_id():
    first = Served("slow-kill")
    ids = [first.client.run("home", wait=True)[0].task]
    killed = kill_mid_wait(first)
    first.client.close()
    assert killed["exit_code"] == EXIT_SESSION_LOST, killed["stderr"]
    assert killed["exit_s"] < 2.0 and "lost while waiting on task" in killed["stderr"]
    ids.append(killed["task"])
    second = Served("slow-kill", port=first.port)
    try:
        after = [second.client.run("home", wait=True)[0].task for _ in range(2)]
    finally:
        second.close()
    assert not set(ids) & set(after), (ids, after)


def test_a_bystanders_heartbeat_does_not_keep_a_silent_owners_task_alive():
    served = Served("slow-bystander")  # serve's default watchdog: 1 s
    try:
        got = bystander(served)
    finally:
        served.close()
    # counted from the owner's last heartbeat, up to one period (50 ms) before it stopped
    assert 1.0 - 0.05 <= got["tripped_after_s"] < 2.0
    assert got["error"].startswith(f"watchdog: no heartbeat from task {got['task']}'s owner")
