"""The command channel between Zenoh and a session: bounded, decoded defensively, never stopped.

Zenoh calls `CommandChannel.offer` for every query on the `command` key, on its own threads;
`offer` never blocks and never decodes (a payload over `MAX_COMMAND_BYTES` is refused by its
length, a full intake is refused as overloaded), so nothing a client sends can hold up
Zenoh's receive path, on which the e-stop arrives too. Two worker threads do the rest, and
only two, whatever the load: one decodes every command (`wire.decode_command`) and answers
all but `run`; a `run` that the queue policy admits goes to the second, which loads and
checks it (up to a second: the guardrail's IK) while `stop`, `pause` or `status` are answered
on the first. Any exception in handling one command is answered as an internal error and
the worker takes the next: no input and no bug ends the channel.
"""

from __future__ import annotations

import json
import queue
import sys
import threading
import traceback
from collections.abc import Callable
from typing import Any

from .protocol import Command, Reply
from .session import Session
from .wire import MAX_COMMAND_BYTES, MalformedCommand, decode_command

__all__ = ["INTAKE_SIZE", "RUN_CHECKS", "CommandChannel", "answer"]

INTAKE_SIZE = 256
"""Commands that may wait to be decoded; more at once are refused as overloaded."""
RUN_CHECKS = 4
"""`run` commands that may wait to be loaded and checked; more at once are refused as busy."""
_ERROR_CHARS = 300


def answer(query: Any, reply: Reply, **qos: Any) -> None:
    """Reply to `query` (with Zenoh `qos`: priority, express) and finalize it (the client's
    `get` returns at once); a client that has gone away is no error."""
    try:
        query.reply(query.key_expr, _encoded(reply), **qos)
    except Exception:  # the querier left, or the session is closing: nobody to tell
        pass
    finally:
        try:
            query.drop()
        except Exception:
            pass


def _encoded(reply: Reply) -> str:
    """`reply` as JSON; text that cannot be encoded (a lone surrogate quoted from a client)
    is escaped rather than the answer lost."""
    try:
        return reply.model_dump_json()
    except ValueError:
        return json.dumps(reply.model_dump(), ensure_ascii=True, default=str)


def payload_of(query: Any) -> bytes | None:
    """A query's payload as bytes (None: it had none)."""
    payload = query.payload
    return None if payload is None else payload.to_bytes()


def internal_error(exc: BaseException) -> Reply:
    """The reply for a bug met while handling a command (the traceback goes to stderr)."""
    traceback.print_exception(exc, file=sys.stderr)
    text = f"internal error: {type(exc).__name__}: {exc}"
    return Reply(accepted=False, reason=text[:_ERROR_CHARS])


class CommandChannel:
    """Queues, decodes and hands commands to `session`; see the module docstring.

    Args:
        session: The session commands go to (`submit`, `busy`, `estop`).
        intake_size: Commands that may wait to be decoded.
        run_checks: `run` commands that may wait to be loaded and checked.
    """

    def __init__(
        self, session: Session, intake_size: int = INTAKE_SIZE, run_checks: int = RUN_CHECKS
    ) -> None:
        self.session = session
        self._intake: queue.Queue[tuple[Any, Command | None]] = queue.Queue(intake_size)
        self._runs: queue.Queue[tuple[Any, Command | None]] = queue.Queue(run_checks)
        self._closing = threading.Event()
        self._workers = [
            threading.Thread(target=self._work, args=(self._intake, self._handle),
                             name="orchestrator-commands", daemon=True),
            threading.Thread(target=self._work, args=(self._runs, self._check_run),
                             name="orchestrator-run-checks", daemon=True),
        ]  # fmt: skip
        for worker in self._workers:
            worker.start()

    # -- Zenoh's threads ------------------------------------------------------------------
    def offer(self, query: Any) -> None:
        """Take one query (Zenoh's callback): queue it, or refuse it at once. Never blocks."""
        try:
            payload = query.payload
            size = 0 if payload is None else len(payload)
            if size > MAX_COMMAND_BYTES:
                answer(query, Reply(accepted=False, reason=f"malformed command: too large: "
                                    f"{size} bytes (limit {MAX_COMMAND_BYTES})"))  # fmt: skip
                return
            self._intake.put_nowait((query, None))
        except queue.Full:
            answer(query, Reply(accepted=False, reason=f"overloaded: {self._intake.maxsize} "
                                "commands are waiting to be read; try again"))  # fmt: skip
        except Exception as exc:  # a Zenoh callback must never raise
            answer(query, internal_error(exc))

    # -- the workers ----------------------------------------------------------------------
    def _work(
        self,
        inbox: queue.Queue[tuple[Any, Command | None]],
        handle: Callable[[Any, Command | None], Reply | None],
    ) -> None:
        while not self._closing.is_set():
            try:
                query, cmd = inbox.get(timeout=0.1)
            except queue.Empty:
                continue
            try:
                reply = handle(query, cmd)
            except Exception as exc:  # a bug in one command's handling: say so, go on
                reply = internal_error(exc)
            if reply is not None:
                answer(query, reply)

    def _handle(self, query: Any, _: Command | None) -> Reply | None:
        try:
            cmd = decode_command(payload_of(query))
        except MalformedCommand as exc:
            return Reply(accepted=False, reason=f"malformed command: {exc}")
        if cmd.op == "run":
            why = self.session.busy(cmd)
            if why is not None:
                return Reply(accepted=False, reason=why)
            try:
                self._runs.put_nowait((query, cmd))
            except queue.Full:
                return Reply(accepted=False, reason=f"busy: {self._runs.maxsize} run commands "
                             "are being checked; try again")  # fmt: skip
            return None  # answered by the run-checks worker
        return self.session.submit(cmd)

    def _check_run(self, query: Any, cmd: Command | None) -> Reply:
        assert cmd is not None
        return self.session.submit(cmd)

    def close(self) -> None:
        """Stop the workers; commands still waiting are told the session is closing."""
        self._closing.set()
        for worker in self._workers:
            worker.join(timeout=2.0)
        for inbox in (self._intake, self._runs):
            while True:
                try:
                    query, _ = inbox.get_nowait()
                except queue.Empty:
                    break
                answer(query, Reply(accepted=False, reason="the session is shutting down"))
