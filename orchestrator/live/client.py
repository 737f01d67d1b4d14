"""The Python client of a live session: the same operations as `orchestrator send`.

    with Client("cell1") as c:            # connects, starts sending heartbeats
        reply, result = c.run("pick_place", wait=True)
        c.estop(); c.reset()
        print(c.status()["state"])

A planner uses it the same way (see `orchestrator.live.planner`).

The client owns the tasks it starts: its heartbeats carry a random owner token that its
`run` commands carry too, and the session's watchdog counts only those. It follows the
session's liveliness token: a `run(wait=True)` whose session goes away (killed, shut down,
the network lost) raises `SessionLost` within about a second (at once when the process
died: its socket closes), never waits on, and never takes the result of, another task
than its own (ids are unique across the session's restarts).
"""

from __future__ import annotations

import json
import socket
import threading
import time
import uuid
from typing import Any

from ..exceptions import OrchestratorError
from .access import Credentials
from .protocol import DEFAULT_ENDPOINT, Command, Reply, config_for, key

__all__ = ["EXIT_SESSION_LOST", "NOT_RESPONDING_S", "Client", "LiveError", "SessionLost"]

EXIT_SESSION_LOST = 5
"""Exit code of `send --wait` / `ask --wait` when the session goes away while waiting."""
NOT_RESPONDING_S = 3.0
"""While waiting on a task: no session heartbeat (10 Hz) for this long and the session is
taken as lost even though its liveliness token stays (a wedged process) [s]."""
_POLL_S = 0.05


class LiveError(OrchestratorError):
    """The session cannot be reached, or did not answer in time."""


class SessionLost(LiveError):
    """The session went away while this client waited on it (exit code 5 in the CLI)."""


class Client:
    """A connection to the session `session`.

    Args:
        session: The session's name.
        connect: Endpoints to connect to (default: the loopback one `serve` listens on).
        heartbeat_s: Period of the heartbeats this client sends (None: send none) [s].
        name: This client's name (in the session's log and messages).
        find_s: How long a command waits for the session to appear (it may be starting) [s].
        credentials: User, password and TLS CA, for a session that asks for them.
    """

    def __init__(
        self,
        session: str,
        connect: list[str] | None = None,
        heartbeat_s: float | None = 0.05,
        name: str = "client",
        find_s: float = 10.0,
        credentials: Credentials | None = None,
    ) -> None:
        import zenoh

        self.session, self.name, self.find_s = session, name, find_s
        self.owner = uuid.uuid4().hex
        """This client's owner token: in its `run` commands and its heartbeats."""
        self.credentials = credentials
        self.endpoints = list(connect or [DEFAULT_ENDPOINT])
        self.z = zenoh.open(config_for(connect=self.endpoints, credentials=credentials))
        self._hb_key = key(session, "clients/heartbeat")
        self._stop = threading.Event()
        self._wake = threading.Event()
        self.alive = False
        """True while the session's liveliness token is seen."""
        self.losses = 0
        """How many times the session's token went away since this client connected."""
        self._token = self.z.liveliness().declare_subscriber(
            key(session, "alive"), self._on_alive, history=True
        )
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
        self._token.undeclare()
        self.z.close()

    def stop_heartbeats(self) -> None:
        """Stop sending heartbeats (the session's watchdog will notice)."""
        self._stop.set()
        if self._hb is not None:
            self._hb.join()
            self._hb = None

    def _beat(self, period: float) -> None:
        while not self._stop.wait(period):
            self.z.put(self._hb_key, self.owner)

    def _on_alive(self, sample: Any) -> None:
        import zenoh

        if sample.kind == zenoh.SampleKind.PUT:
            self.alive = True
        else:
            self.alive = False
            self.losses += 1
        self._wake.set()

    # -- commands -------------------------------------------------------------------------
    def _query(self, leaf: str, payload: str, timeout: float, **qos: Any) -> Reply | None:
        """One query on `leaf`; the first usable reply (None: none came)."""
        for reply in self.z.get(key(self.session, leaf), payload=payload, timeout=timeout, **qos):
            if reply.ok is not None:
                return Reply.model_validate_json(reply.ok.payload.to_string())
        return None

    def _ask(self, leaf: str, payload: str, timeout: float) -> Reply:
        """Query `leaf` until answered, retrying while the session may still be starting."""
        deadline = time.monotonic() + self.find_s
        while True:  # no answer at all: the session is not (yet) there; nothing was received
            reply = self._query(leaf, payload, timeout)
            if reply is not None:
                return reply
            if time.monotonic() >= deadline:
                break
            time.sleep(0.1)
        raise LiveError(self._why_unanswered(leaf))

    def _why_unanswered(self, leaf: str) -> str:
        at = ", ".join(self.endpoints)
        if self.alive:
            return (
                f"session {self.session!r} at {at} is there but did not answer on {leaf!r}"
                + (f" (user {self.credentials.user!r} may be a viewer: viewers watch and "
                   "e-stop only)" if self.credentials and self.credentials.user else "")
            )  # fmt: skip
        if any(_listening(e) for e in self.endpoints):
            return (
                f"no session {self.session!r} answered at {at}: something listens there but "
                "no Zenoh session could be opened with it (wrong user or password, a TLS "
                "setting, credentials given to a session without authentication, or the "
                "other way round)"
            )
        return (
            f"no session {self.session!r} answered at {at} (is `orchestrator serve ... "
            f"--session {self.session}` running there?)"
        )

    def command(
        self, op: str, machine: str | None = None, sets: list[str] | None = None,
        timeout: float = 30.0, preempt: bool = False, snapshot: str | None = None,
    ) -> Reply:  # fmt: skip
        """Send one command and return the session's reply (`snapshot`: the name a `snapshot`
        writes or a `restore` reads).

        Raises:
            LiveError: No session of that name answered within `timeout` seconds.
        """
        cmd = Command(op=op, machine=machine, set=list(sets or []), client=self.name,  # type: ignore[arg-type]
                      owner=self.owner, preempt=preempt, snapshot=snapshot)  # fmt: skip
        return self._ask("command", cmd.model_dump_json(), timeout)

    def run(
        self, machine: str | None = None, sets: list[str] | None = None, wait: bool = False,
        timeout: float = 600.0, preempt: bool = False,
    ) -> tuple[Reply, dict[str, Any] | None]:  # fmt: skip
        """Start a task (or queue it, by the session's policy); with `wait`, block until it
        ends and return its result too (None: it never started; the reason is logged in the
        session's events).

        Raises:
            SessionLost: The session went away (or stopped answering) while waiting.
            LiveError: The session did not answer, or the task did not end within `timeout`.
        """
        ends: dict[str, dict[str, Any]] = {}
        beat = [time.monotonic()]

        def on_event(sample: Any) -> None:
            try:
                msg = json.loads(sample.payload.to_string())
            except ValueError:
                return
            if isinstance(msg, dict) and msg.get("event") in ("task_end", "shutdown"):
                ends[str(msg.get("task", ""))] = msg
                self._wake.set()

        def on_beat(sample: Any) -> None:
            beat[0] = time.monotonic()

        subs = []
        if wait:
            subs = [self.z.declare_subscriber(key(self.session, "events"), on_event),
                    self.z.declare_subscriber(key(self.session, "heartbeat"), on_beat)]  # fmt: skip
        losses = self.losses  # before sending: a loss after this is this task's
        try:
            reply = self.command("run", machine, sets, preempt=preempt)
            if not wait or not reply.accepted or reply.task is None:
                return reply, None
            beat[0] = time.monotonic()
            deadline = beat[0] + timeout
            while True:
                end = ends.get(reply.task)
                if end is not None:
                    return reply, end.get("result") or None
                if "" in ends:  # the session shut down before the task ended
                    raise SessionLost(f"session {self.session!r} shut down before task "
                                      f"{reply.task} ended")  # fmt: skip
                if self.losses > losses:
                    raise SessionLost(f"session {self.session!r} lost while waiting on task "
                                      f"{reply.task}: its liveliness token went away (the "
                                      "server stopped, or the network to it failed)")  # fmt: skip
                now = time.monotonic()
                if now - beat[0] > NOT_RESPONDING_S:
                    raise SessionLost(f"session {self.session!r} not responding while waiting "
                                      f"on task {reply.task}: no heartbeat for "
                                      f"{now - beat[0]:.1f} s")  # fmt: skip
                if now >= deadline:
                    raise LiveError(f"task {reply.task} did not end within {timeout} s")
                self._wake.wait(_POLL_S)
                self._wake.clear()
        finally:
            for sub in subs:
                sub.undeclare()

    def status(self) -> dict[str, Any]:
        """The session's status (state, task, last result, times); a viewer may ask too."""
        reply = self._ask("status", "", 30.0)
        return reply.status or {}

    def estop(self) -> Reply:
        """E-stop on the session's own e-stop key (never queued behind other commands): at
        Zenoh's real-time priority, express (not batched), so it also overtakes this
        client's own commands still waiting to be sent."""
        import zenoh

        cmd = Command(op="estop", client=self.name)
        reply = self._query("estop", cmd.model_dump_json(), 5.0,
                            priority=zenoh.Priority.REAL_TIME, express=True)  # fmt: skip
        return reply if reply is not None else self.command("estop")

    def stop(self) -> Reply:
        return self.command("stop")

    def reset(self) -> Reply:
        return self.command("reset")

    def pause(self) -> Reply:
        return self.command("pause")

    def resume(self) -> Reply:
        return self.command("resume")

    def shutdown(self) -> Reply:
        return self.command("shutdown")


def _listening(endpoint: str) -> bool:
    """Whether a TCP listener answers at a `tcp/` or `tls/` endpoint (for the error message)."""
    proto, _, rest = endpoint.partition("/")
    if proto not in ("tcp", "tls"):
        return False
    host, _, port = rest.split("#", 1)[0].rpartition(":")
    try:
        with socket.create_connection((host.strip("[]"), int(port)), timeout=0.5):
            return True
    except (OSError, ValueError):
        return False
