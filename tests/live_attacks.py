"""Attacks on a live session's command channel (issue 26): the payload generators and the
procedures that tests/test_live_attack.py (its slow part), tests/test_live_channel.py (small
doses) and bench/live_attack.py (the measured campaign) share.

Every procedure talks Zenoh on 127.0.0.1 to a real session: `Served` starts
`orchestrator serve` as a subprocess (so it can be SIGKILLed and its memory read).
"""

from __future__ import annotations

import json
import os
import random
import signal
import socket
import subprocess
import sys
import time
from collections import Counter
from dataclasses import dataclass, field
from typing import Any

from orchestrator.live.client import Client
from orchestrator.live.protocol import config_for, key
from orchestrator.live.wire import MAX_COMMAND_BYTES, MAX_DEPTH

CATEGORIES = (
    "random bytes",
    "invalid UTF-8",
    "truncated",
    "deep",
    "huge",
    "binary",
    "duplicate keys",
    "wrong shape",
)
VALID = (
    b'{"op": "status"}',
    b'{"op": "run", "machine": "reach", "set": ["target=[0.5, 0.1, 0.4]"], "client": "x"}',
    b'{"op": "pause", "client": "attacker"}',
    b'{"op": "estop", "client": "attacker", "owner": "0123"}',
)


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def malformed(category: str, rng: random.Random) -> bytes:
    """One payload of `category` that is not a command (every one must be refused)."""
    base = rng.choice(VALID)
    if category == "random bytes":
        return rng.randbytes(rng.randint(1, 2048))
    if category == "invalid UTF-8":
        cut = rng.randint(1, len(base) - 1)
        bad = rng.choice([b"\xff", b"\xc3\x28", b"\xe2\x82", b"\xf0\x28\x8c\xbc", b"\xed\xa0\x80"])
        return base[:cut] + bad + base[cut:]
    if category == "truncated":
        return base[: rng.randint(1, len(base) - 1)]
    if category == "deep":
        n = rng.randint(MAX_DEPTH + 1, 20_000)
        opener, closer = rng.choice([("[", "]"), ('{"a":', "}")])
        inner = opener * n + "1" + closer * n
        return f'{{"op": "status", "set": {inner}}}'.encode()[:MAX_COMMAND_BYTES]
    if category == "huge":
        size = rng.choice([MAX_COMMAND_BYTES + 1, 200_000, 1_000_000])
        return b'{"op": "status", "client": "' + b"x" * size + b'"}'
    if category == "binary":
        return bytes(rng.choice([0, 1, 0x7F, 0x1B, 0xFE]) for _ in range(rng.randint(1, 512)))
    if category == "duplicate keys":
        return rng.choice([
            b'{"op": "status", "op": "estop"}',
            b'{"op": "run", "machine": "home", "machine": "reach"}',
            b'{"op": "status", "client": "a", "client": "b"}',
            b'{"op": "run", "set": [], "preempt": false, "preempt": true}',
        ])  # fmt: skip
    if category == "wrong shape":
        return rng.choice([
            b"[]", b"null", b"1", b'"status"', b"{}", b'{"op": "jump"}',
            b'{"op": "status", "extra": 1}', b'{"op": 7}', b'{"op": "run", "set": "x=1"}',
            b'{"op": "status", "set": [NaN]}', b'{"op": "status", "client": "' + b"c" * 200 + b'"}',
            b'{"op": "run", "machine": {"$ref": "/etc/passwd"}}',
        ])  # fmt: skip
    raise ValueError(category)


def malformed_payloads(n: int, seed: int = 0) -> list[tuple[str, bytes]]:
    """`n` malformed payloads, the categories in turn."""
    rng = random.Random(seed)
    return [(c := CATEGORIES[i % len(CATEGORIES)], malformed(c, rng)) for i in range(n)]


def get_raw(z: Any, leaf_key: str, payload: bytes, timeout: float = 10.0) -> dict | None:
    """One query with a raw payload; the first reply decoded (None: no reply)."""
    for reply in z.get(leaf_key, payload=payload, timeout=timeout):
        if reply.ok is not None:
            return json.loads(reply.ok.payload.to_string())
    return None


@dataclass
class MalformedTally:
    """What a malformed campaign saw."""

    sent: int = 0
    refused: int = 0
    unanswered: int = 0
    accepted: list[str] = field(default_factory=list)
    status_answered: int = 0
    by_category: Counter = field(default_factory=Counter)
    reasons: Counter = field(default_factory=Counter)


def attack_malformed(z: Any, session: str, payloads: list[tuple[str, bytes]]) -> MalformedTally:
    """Send each payload on `command`, then a `status` there: every payload must be refused
    with a named reason and every status answered."""
    tally = MalformedTally()
    cmd_key = key(session, "command")
    for category, payload in payloads:
        tally.sent += 1
        reply = get_raw(z, cmd_key, payload)
        if reply is None:
            tally.unanswered += 1
        elif reply["accepted"]:
            tally.accepted.append(f"{category}: {payload[:80]!r}")
        else:
            tally.refused += 1
            tally.by_category[category] += 1
            tally.reasons[reply["reason"].split(":")[1].strip() if ":" in reply["reason"]
                          else reply["reason"]] += 1  # fmt: skip
        status = get_raw(z, cmd_key, b'{"op": "status"}')
        if status is not None and status["accepted"] and status["status"]:
            tally.status_answered += 1
    return tally


def flood(z: Any, session: str, n: int, seed: int = 0, window: int | None = None) -> Counter:
    """`n` commands sent without waiting for their replies (a mix: status, run, pause,
    malformed; at most `window` in flight, None: all at once), then every reply collected.
    Returns counts: accepted, refused (by the first words of the reason), unanswered."""
    rng = random.Random(seed)
    cmd_key = key(session, "command")
    kinds = [b'{"op": "status"}', VALID[1], b'{"op": "pause"}', b'{"op": "status", "op": 1}',
             b'{"op": "run", "machine": "home", "client": "flood"}', rng.randbytes(64)]  # fmt: skip
    counts: Counter = Counter()
    in_flight: list[Any] = []

    def collect(handle: Any) -> None:
        reply = None
        for r in handle:
            if r.ok is not None:
                reply = json.loads(r.ok.payload.to_string())
                break
        if reply is None:
            counts["unanswered"] += 1
        elif reply["accepted"]:
            counts["accepted"] += 1
        else:
            counts["refused: " + reply["reason"].split(":")[0]] += 1

    for i in range(n):
        in_flight.append(z.get(cmd_key, payload=kinds[i % len(kinds)], timeout=120.0))
        if window is not None and len(in_flight) >= window:
            collect(in_flight.pop(0))
    for handle in in_flight:
        collect(handle)
    return counts


def hold_paused_task(served: Served) -> str:
    """Start a pick and pause it: the session is busy and its task frozen, so what memory a
    flood then costs is the channel's own (a task running meanwhile allocates as it goes)."""
    c = served.client
    reply, _ = c.run("pick_place")
    assert reply.accepted, reply.reason
    wait_for(lambda: c.status()["state"] in ("MOVING", "GRASPING"), 120.0)
    assert c.pause().accepted
    wait_for(lambda: c.status()["state"] == "PAUSED", 30.0)
    assert reply.task is not None
    return reply.task


class Served:
    """`orchestrator serve pick_place` as a subprocess on 127.0.0.1.

    Args:
        name: The session's name.
        args: More `serve` options.
        port: The port (default: a free one; give the old one to restart in place).
    """

    def __init__(self, name: str, *args: str, port: int | None = None) -> None:
        self.name = name
        self.port = port or free_port()
        self.endpoint = f"tcp/127.0.0.1:{self.port}"
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "orchestrator.cli", "serve", "pick_place", "--session", name,
             "--seed", "3", "--listen", self.endpoint, *args],
            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
        )  # fmt: skip
        self.client = Client(name, [self.endpoint], name="attack", find_s=120.0)
        self.client.status()  # waits for the session to come up

    def raw(self) -> Any:
        """A bare Zenoh session connected to it (no heartbeats, no checks)."""
        import zenoh

        return zenoh.open(config_for(connect=[self.endpoint]))

    def rss_mb(self) -> float:
        import psutil

        return psutil.Process(self.proc.pid).memory_info().rss / 2**20

    def threads(self) -> int:
        import psutil

        return psutil.Process(self.proc.pid).num_threads()

    def kill(self) -> None:
        os.kill(self.proc.pid, signal.SIGKILL)
        self.proc.wait(timeout=30)

    def close(self) -> None:
        try:
            if self.proc.poll() is None:
                self.client.shutdown()
                self.proc.wait(timeout=30)
        except Exception:
            pass
        finally:
            self.client.close()
            if self.proc.poll() is None:
                self.proc.kill()
                self.proc.wait()


def send_wait(served: Served, *args: str) -> subprocess.Popen:
    """`orchestrator send NAME run ... --wait` as a subprocess (stdout/stderr piped)."""
    return subprocess.Popen(
        [sys.executable, "-m", "orchestrator.cli", "send", served.name, "run", *args, "--wait",
         "--connect", served.endpoint],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip


def wait_for(predicate: Any, timeout: float, period: float = 0.02) -> Any:
    """Poll `predicate` until it returns something truthy; that, or AssertionError."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        value = predicate()
        if value:
            return value
        time.sleep(period)
    raise AssertionError(f"not within {timeout} s")


def kill_mid_wait(served: Served) -> dict[str, Any]:
    """A `send --wait` waits on a long task; the server is SIGKILLed: how long the client
    takes to exit, and with what code."""
    proc = send_wait(served, "reach", "--set", "target=[0.45, -0.25, 0.55]")
    wait_for(lambda: served.client.status()["state"] == "MOVING", 120.0)
    task_id = served.client.status()["task"]["id"]
    t0 = time.monotonic()
    served.kill()
    try:
        proc.wait(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
    elapsed = time.monotonic() - t0
    assert proc.stderr is not None
    return {"task": task_id, "exit_code": proc.returncode, "exit_s": round(elapsed, 3),
            "stderr": proc.stderr.read().strip()}  # fmt: skip


def bystander(served: Served) -> dict[str, Any]:
    """The owner of a task falls silent while a bystander keeps beating: how long after the
    owner stops until the session is in ERROR (the watchdog's limit, if only the owner's
    heartbeats count)."""
    with (
        Client(served.name, [served.endpoint], name="owner") as owner,
        Client(served.name, [served.endpoint], name="bystander") as other,
    ):
        reply, _ = owner.run("pick_place")  # ~5 s at --speed 1: longer than the watchdog
        assert reply.accepted, reply.reason
        wait_for(lambda: other.status()["state"] in ("MOVING", "GRASPING"), 60.0)
        t0 = time.monotonic()
        owner.stop_heartbeats()
        status = wait_for(lambda: (s := other.status())["state"] == "ERROR" and s, 30.0)
        tripped_s = time.monotonic() - t0
        other.reset()
    return {"tripped_after_s": round(tripped_s, 3), "error": status["error"],
            "task": reply.task}  # fmt: skip
