"""A real `serve` on 127.0.0.1 in this process (a thread), and what it publishes, for the
tests of the live protocol (tests/test_live_latch.py, tests/test_live_model.py).

In-process (not a subprocess) so a test can reach into the session it serves: a mutation test
switches a safety check off and shows the protocol tests then fail. Everything still goes
through Zenoh: commands, the e-stop key, status and events.
"""

from __future__ import annotations

import json
import threading
import time
from pathlib import Path
from typing import Any

from orchestrator.live.protocol import config_for, key
from orchestrator.live.server import serve
from orchestrator.live.session import Session

from .live_attacks import free_port

STILL_RAD_S = 0.01
"""Largest joint speed of an arm at rest [rad/s] (the issue's bound)."""
SETTLE_S = 0.2
"""Simulated time an e-stop may take to bring the arm to rest [s]."""


class LiveServer:
    """`serve` of a `pick_place` session on a free loopback port, in a thread.

    Args:
        folder: Where its snapshots go (and machines it may load from).
        name: The session's name.
        session_kw: More `Session` arguments (speed, watchdog_s, snapshot caps...).
    """

    def __init__(self, folder: Path, name: str = "model", **session_kw: Any) -> None:
        import zenoh

        self.name = name
        self.endpoint = f"tcp/127.0.0.1:{free_port()}"
        kw = {"seed": 3, "speed": 1.0, "snapshot_dir": folder / "snaps", "allow_paths": [folder]}
        self.session = Session("pick_place", name, **{**kw, **session_kw})
        self._stop = threading.Event()
        ready = threading.Event()
        self.thread = threading.Thread(
            target=serve, args=(self.session, [self.endpoint]),
            kwargs={"ready": ready.set, "stop": self._stop}, daemon=True,
        )  # fmt: skip
        self.thread.start()
        if not ready.wait(60.0):
            raise RuntimeError("serve did not come up in 60 s")
        self.lock = threading.Lock()
        self.events: list[dict[str, Any]] = []
        self.statuses: list[dict[str, Any]] = []
        self.published: list[tuple[str, dict[str, Any]]] = []
        """Events and statuses together, in the order received (for a failure's report)."""
        self.z = zenoh.open(config_for(connect=[self.endpoint]))
        self._subs = [
            self.z.declare_subscriber(key(name, "events"), self._on("events")),
            self.z.declare_subscriber(key(name, "status"), self._on("statuses")),
        ]
        time.sleep(0.3)  # the subscriptions reach the session

    def _on(self, field: str) -> Any:
        def take(sample: Any) -> None:
            msg = json.loads(sample.payload.to_string())
            with self.lock:
                getattr(self, field).append(msg)
                self.published.append((field, msg))

        return take

    def snapshot_events(self) -> tuple[list[dict[str, Any]], list[dict[str, Any]]]:
        """Copies of the events and statuses received so far."""
        with self.lock:
            return list(self.events), list(self.statuses)

    def wait_status(self, predicate: Any, timeout: float) -> dict[str, Any]:
        """The first published status (from now on) for which `predicate` holds."""
        with self.lock:
            start = len(self.statuses)
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            with self.lock:
                fresh = self.statuses[start:]
            for status in fresh:
                if predicate(status):
                    return status
            time.sleep(0.02)
        raise AssertionError(f"no status matched within {timeout} s")

    def close(self) -> None:
        for sub in self._subs:
            sub.undeclare()
        self.z.close()
        self._stop.set()
        self.thread.join(timeout=30.0)


def motion_while_latched(statuses: list[dict[str, Any]], stop_t: float) -> list[dict[str, Any]]:
    """Among `statuses` (in the order published, all while latched), those whose window shows
    the arm faster than `STILL_RAD_S` on some physics step, from the first window that starts
    `SETTLE_S` after the stop (simulated time `stop_t`) on. A window later in the stream
    counts whatever its time says (a restore that slipped through would move time back)."""
    moving, started = [], False
    for status in statuses:
        speed = status.get("arm_speed")
        if not speed or speed["t0"] is None:
            continue
        started = started or speed["t0"] >= stop_t + SETTLE_S
        if started and speed["peak"] > STILL_RAD_S:
            moving.append(status)
    return moving
