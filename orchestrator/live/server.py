"""`orchestrator serve`: a session behind Zenoh.

Keys under `orchestrator/<session>/`: `command` (a queryable: a `Command` in, a `Reply` out),
`status` (10 Hz), `heartbeat` (the session's, 10 Hz), `events` (task start and end with its
result, e-stop, watchdog, reset, shutdown) and `clients/heartbeat` (where clients prove
they are alive). A command is answered on a thread of its own when it needs work (a `run`'s
loading and goal checks), so an `estop` is never queued behind one.
"""

from __future__ import annotations

import signal
import threading
import time
from collections.abc import Callable
from typing import Any

from pydantic import ValidationError

from ..engine.strict_json import dumps
from .protocol import Command, Reply, config_for, key
from .session import Session

__all__ = ["POLL_S", "SWITCH_INTERVAL_S", "serve"]

POLL_S = 0.0005
"""Period the command channel is polled at when empty [s]."""
SWITCH_INTERVAL_S = 0.0002
"""The interpreter's thread switch interval while serving (default 5 ms) [s]."""


def serve(
    session: Session,
    listen: list[str],
    connect: list[str] | None = None,
    ready: Callable[[], None] | None = None,
    stop: threading.Event | None = None,
) -> None:
    """Open Zenoh, answer commands and publish until the session shuts down (or SIGINT/TERM).

    Args:
        session: The session to run (its loop runs on this thread).
        listen: Endpoints to listen on, e.g. `tcp/127.0.0.1:7447`.
        connect: Endpoints of routers or peers to connect to.
        ready: Called once the keys are declared (the CLI prints its ready line).
        stop: Set it to end the session from another thread (as SIGINT does).
    """
    import sys

    import zenoh

    # the loop holds the GIL through a whole control tick; a command's thread should not
    # wait the default 5 ms for it
    sys.setswitchinterval(SWITCH_INTERVAL_S)
    z = zenoh.open(config_for(listen, connect))
    name = session.name
    pubs = {
        leaf: z.declare_publisher(key(name, leaf)) for leaf in ("status", "heartbeat", "events")
    }

    def publish(leaf: str, msg: dict[str, Any]) -> None:
        pubs[leaf].put(dumps(msg))

    session.publish = publish

    def answer(query: Any, cmd: Command) -> None:
        try:
            reply = session.submit(cmd)
        except Exception as exc:  # a bug must not take the session down: say what it was
            reply = Reply(accepted=False, reason=f"internal error: {type(exc).__name__}: {exc}")
        query.reply(query.key_expr, reply.model_dump_json())
        query.drop()

    def on_query(query: Any) -> None:
        text = query.payload.to_string() if query.payload is not None else ""
        try:
            cmd = Command.model_validate_json(text)
        except ValidationError as exc:
            problems = "; ".join(
                f"{'.'.join(str(p) for p in e['loc']) or 'command'}: {e['msg']}"
                for e in exc.errors()
            )
            reply = Reply(accepted=False, reason=f"malformed command: {problems}")
            query.reply(query.key_expr, reply.model_dump_json())
            query.drop()
            return
        if cmd.op == "run":  # loading and goal checks take a while: never block an estop
            threading.Thread(target=answer, args=(query, cmd), daemon=True).start()
        else:
            answer(query, cmd)

    # a channel, not a callback: a query may then be answered from another thread
    queryable = z.declare_queryable(key(name, "command"))

    closing = threading.Event()

    def receive() -> None:  # polled, so that closing never waits on a blocked recv()
        while not closing.is_set():
            query = queryable.try_recv()
            if query is None:
                time.sleep(POLL_S)
            else:
                on_query(query)

    receiver = threading.Thread(target=receive, name="orchestrator-commands", daemon=True)
    receiver.start()
    subscriber = z.declare_subscriber(
        key(name, "clients/heartbeat"), lambda sample: session.heartbeat()
    )
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
        closing.set()
        receiver.join(timeout=2.0)
        queryable.undeclare()
        subscriber.undeclare()
        z.close()
