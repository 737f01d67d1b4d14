"""The Python client of a live session: the same operations as `orchestrator send`.

    with Client("cell1") as c:            # connects, starts sending heartbeats
        reply, result = c.run("pick_place", wait=True)
        c.estop(); c.reset()
        print(c.status()["state"])

A planner uses it the same way (see `orchestrator.live.planner`).
"""

from __future__ import annotations

import json
import threading
import time
from typing import Any

from ..exceptions import OrchestratorError
from .protocol import DEFAULT_ENDPOINT, Command, Reply, config_for, key

__all__ = ["Client", "LiveError"]


class LiveError(OrchestratorError):
    """The session cannot be reached, or did not answer in time."""


class Client:
    """A connection to the session `session`.

    Args:
        session: The session's name.
        connect: Endpoints to connect to (default: the loopback one `serve` listens on).
        heartbeat_s: Period of the heartbeats this client sends (None: send none) [s].
        name: This client's name (in the session's log).
        find_s: How long a command waits for the session to appear (it may be starting) [s].
    """

    def __init__(
        self,
        session: str,
        connect: list[str] | None = None,
        heartbeat_s: float | None = 0.05,
        name: str = "client",
        find_s: float = 10.0,
    ) -> None:
        import zenoh

        self.session, self.name, self.find_s = session, name, find_s
        self.endpoints = list(connect or [DEFAULT_ENDPOINT])
        self.z = zenoh.open(config_for(connect=self.endpoints))
        self._hb_key = key(session, "clients/heartbeat")
        self._stop = threading.Event()
        self._hb: threading.Thread | None = None
        if heartbeat_s is not None:
            self._hb = threading.Thread(target=self._beat, args=(heartbeat_s,), daemon=True)
            self._hb.start()

    def __enter__(self) -> Client:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        """Stop the heartbeats and disconnect."""
        self.stop_heartbeats()
        self.z.close()

    def stop_heartbeats(self) -> None:
        """Stop sending heartbeats (the session's watchdog will notice)."""
        self._stop.set()
        if self._hb is not None:
            self._hb.join()
            self._hb = None

    def _beat(self, period: float) -> None:
        while not self._stop.wait(period):
            self.z.put(self._hb_key, self.name)

    # -- commands -------------------------------------------------------------------------
    def command(
        self, op: str, machine: str | None = None, sets: list[str] | None = None,
        timeout: float = 30.0,
    ) -> Reply:  # fmt: skip
        """Send one command and return the session's reply.

        Raises:
            LiveError: No session of that name answered within `timeout` seconds.
        """
        cmd = Command(op=op, machine=machine, set=list(sets or []), client=self.name)  # type: ignore[arg-type]
        payload = cmd.model_dump_json()
        deadline = time.monotonic() + self.find_s
        while True:  # no answer at all: the session is not (yet) there; nothing was received
            replies = self.z.get(key(self.session, "command"), payload=payload, timeout=timeout)
            for reply in replies:
                if reply.ok is not None:
                    return Reply.model_validate_json(reply.ok.payload.to_string())
            if time.monotonic() >= deadline:
                break
            time.sleep(0.1)
        raise LiveError(
            f"no session {self.session!r} answered at {', '.join(self.endpoints)} "
            f"(is `orchestrator serve ... --session {self.session}` running there?)"
        )

    def run(
        self, machine: str | None = None, sets: list[str] | None = None, wait: bool = False,
        timeout: float = 600.0,
    ) -> tuple[Reply, dict[str, Any] | None]:  # fmt: skip
        """Queue a task; with `wait`, block until it ends and return its result too.

        Raises:
            LiveError: The session did not answer, or the task did not end within `timeout`.
        """
        done = threading.Event()
        ends: dict[int, dict[str, Any] | None] = {}

        def on_event(sample: Any) -> None:
            msg = json.loads(sample.payload.to_string())
            if msg.get("event") == "task_end":
                ends[msg["task"]] = msg.get("result")
                done.set()
            elif msg.get("event") == "shutdown":
                done.set()

        sub = self.z.declare_subscriber(key(self.session, "events"), on_event) if wait else None
        try:
            reply = self.command("run", machine, sets)
            if not wait or not reply.accepted or reply.task is None:
                return reply, None
            deadline = time.monotonic() + timeout
            while reply.task not in ends:
                if not done.wait(max(0.0, deadline - time.monotonic())):
                    raise LiveError(f"task {reply.task} did not end within {timeout} s")
                done.clear()
                if reply.task not in ends and not self._alive():
                    raise LiveError(f"the session ended before task {reply.task} did")
            return reply, ends[reply.task]
        finally:
            if sub is not None:
                sub.undeclare()

    def _alive(self) -> bool:
        find_s, self.find_s = self.find_s, 0.0
        try:
            self.command("status", timeout=2.0)
        except LiveError:
            return False
        finally:
            self.find_s = find_s
        return True

    def status(self) -> dict[str, Any]:
        """The session's status (state, task, last result, times)."""
        reply = self.command("status")
        return reply.status or {}

    def stop(self) -> Reply:
        return self.command("stop")

    def estop(self) -> Reply:
        return self.command("estop")

    def reset(self) -> Reply:
        return self.command("reset")

    def pause(self) -> Reply:
        return self.command("pause")

    def resume(self) -> Reply:
        return self.command("resume")

    def shutdown(self) -> Reply:
        return self.command("shutdown")
