"""`orchestrator serve`: a session behind Zenoh.

Keys under `orchestrator/<session>/`: `command` (a queryable: a `Command` in, a `Reply` out,
through the bounded `CommandChannel`), `estop` (a queryable and a subscriber of its own: any
query or put there e-stops at once, from Zenoh's thread, without waiting behind a command),
`status` (published at 10 Hz, and a queryable answering it at once), `heartbeat` (the
session's, 10 Hz), `events` (task start and end with its result, e-stop, watchdog, reset,
shutdown), `clients/heartbeat` (clients' heartbeats, each carrying its owner token) and
`alive` (the session's liveliness token: clients notice at once when it goes).
"""

from __future__ import annotations

import signal
import threading
from collections.abc import Callable
from typing import Any

from ..engine.strict_json import dumps
from .access import Credentials, ServerAccess
from .channel import CommandChannel, answer, internal_error, payload_of
from .protocol import Reply, config_for, key
from .session import Session
from .wire import MalformedCommand, decode_command

__all__ = ["SWITCH_INTERVAL_S", "serve"]

SWITCH_INTERVAL_S = 0.0002
"""The interpreter's thread switch interval while serving (default 5 ms) [s]."""
_OWNER_CHARS = 128


def _estop_source(payload: bytes | None) -> str:
    """Who an e-stop says it comes from: the `client` of a command payload, if there is a
    readable one (an e-stop is never refused for its payload)."""
    try:
        return f"e-stop key, from {decode_command(payload).client or 'a client'}"
    except MalformedCommand:
        return "e-stop key"


def serve(
    session: Session,
    listen: list[str],
    connect: list[str] | None = None,
    ready: Callable[[], None] | None = None,
    stop: threading.Event | None = None,
    access: ServerAccess | None = None,
    credentials: Credentials | None = None,
) -> None:
    """Open Zenoh, answer commands and publish until the session shuts down (or SIGINT/TERM).

    Args:
        session: The session to run (its loop runs on this thread).
        listen: Endpoints to listen on, e.g. `tcp/127.0.0.1:7447`.
        connect: Endpoints of routers or peers to connect to.
        ready: Called once the keys are declared (the CLI prints its ready line).
        stop: Set it to end the session from another thread (as SIGINT does).
        access: Authentication, access control and TLS (None: none; loopback only).
        credentials: What the session presents when it connects out (`connect`).

    Raises:
        AccessError: A non-loopback endpoint without authentication, or unusable settings.
    """
    import sys

    import zenoh

    name = session.name
    conf = config_for(listen, connect, credentials=credentials,
                      server=access or ServerAccess(), session=name)  # fmt: skip
    # the loop holds the GIL through a whole control tick; a command's thread should not
    # wait the default 5 ms for it
    sys.setswitchinterval(SWITCH_INTERVAL_S)
    z = zenoh.open(conf)
    pubs = {
        leaf: z.declare_publisher(key(name, leaf)) for leaf in ("status", "heartbeat", "events")
    }

    def publish(leaf: str, msg: dict[str, Any]) -> None:
        pubs[leaf].put(dumps(msg))

    session.publish = publish
    channel = CommandChannel(session)

    urgent = {"express": True}  # a reply takes its query's priority (real time, the client's)

    def on_estop_query(query: Any) -> None:
        try:
            answer(query, session.estop(_estop_source(payload_of(query))), **urgent)
        except Exception as exc:  # never raise into Zenoh; the e-stop itself cannot fail
            answer(query, internal_error(exc), **urgent)

    def on_estop_sample(sample: Any) -> None:
        session.estop(_estop_source(sample.payload.to_bytes()))

    def on_status(query: Any) -> None:
        try:
            answer(query, Reply(accepted=True, status=session.status()))
        except Exception as exc:
            answer(query, internal_error(exc))

    def on_heartbeat(sample: Any) -> None:
        raw = sample.payload.to_bytes()
        if len(raw) <= _OWNER_CHARS:
            session.heartbeat(raw.decode("utf-8", "replace"))

    declared: list[Any] = [
        z.declare_queryable(key(name, "estop"), on_estop_query),
        z.declare_subscriber(key(name, "estop"), on_estop_sample),
        z.declare_queryable(key(name, "status"), on_status),
        z.declare_queryable(key(name, "command"), channel.offer),
        z.declare_subscriber(key(name, "clients/heartbeat"), on_heartbeat),
    ]
    token = z.liveliness().declare_token(key(name, "alive"))
    stop = stop or threading.Event()
    previous = {}
    if threading.current_thread() is threading.main_thread():  # Ctrl-C, kill: a clean close
        previous = {
            s: signal.signal(s, lambda *_: stop.set()) for s in (signal.SIGINT, signal.SIGTERM)
        }
    try:
        if ready is not None:
            ready()
        session.run(stop)
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler)
        token.undeclare()
        for entity in declared:
            entity.undeclare()
        channel.close()
        z.close()
