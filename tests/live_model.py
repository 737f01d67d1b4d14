"""A reference model of the live protocol as docs/live.md states it, and a driver that sends
commands to a real `serve` from two clients (tests/test_live_model.py).

The model (`ProtocolModel`) reads what a session publishes (its events, its status stream)
and the answers its clients got, and reports every departure from docs/live.md:

* latching: ESTOPPED and ERROR hold until a `reset` is applied (the `reset` event); nothing
  else leaves them (an e-stop on top of an ERROR shows ESTOPPED: allowed); no task starts and
  no restore is applied while latched; a `reset` is applied only if a client sent one;
* motion: while latched the arm is still (no physics step faster than 0.01 rad/s, from 0.2 s
  after the stop; the status's `arm_speed` windows, live/motion.py);
* answers: every command gets exactly one answer, never an internal error;
* ids: no task id is given twice (accepted runs, started tasks, restored tasks);
* recovery: a `recover` that succeeds leaves the world unblocked (its end is not followed by
  BLOCKED), and `settle` gets every session it is handed back to IDLE (e-stop, reset, and
  `recover` when the world is BLOCKED), or fails naming why.

A failure prints the command script (each command's client, JSON and the delay after it);
`python -m tests.live_model SCRIPT.json` replays it against a fresh session and prints what
the model finds.
"""

from __future__ import annotations

import json
import sys
import threading
import time
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from orchestrator.live.protocol import Command, key

from .live_server import LiveServer, motion_while_latched

LATCHED = ("ESTOPPED", "ERROR")
OPS = ("run", "pause", "resume", "stop", "estop", "reset", "snapshot", "restore", "reload",
       "recover", "set", "heartbeat", "preempt")  # fmt: skip
"""Every command the driver sends (`set`: a run with values; `preempt`: a run that preempts;
`heartbeat`: a put on clients/heartbeat with the client's owner token)."""
STATS: Counter[str] = Counter()
"""What the drivers of this process did and saw (interleavings, steps, states, events)."""
SNAPSHOTS = ("m0", "m1")
"""Snapshot names the driver writes and restores (few: restores find them)."""


@dataclass
class ProtocolModel:
    """The protocol's rules, checked on what the session publishes (see the module doc)."""

    latched: str | None = None
    resets_sent: int = 0
    resets_seen: int = 0
    started: set[str] = field(default_factory=set)
    given: set[str] = field(default_factory=set)
    violations: list[str] = field(default_factory=list)
    recovered: dict[str, Any] | None = None
    """The result of a `recover` that just succeeded (until the next state event)."""

    def event(self, e: dict[str, Any]) -> None:
        """One event, in the order the session published it."""
        kind = e.get("event")
        if kind == "estop":
            self.latched = "ESTOPPED"
        elif kind in ("watchdog", "internal_error"):
            self.latched = self.latched or "ERROR"
        elif kind == "reset":
            self.resets_seen += 1
            if self.resets_seen > self.resets_sent:
                self.violations.append(f"a reset applied that no client sent: {e}")
            self.latched = None
        elif kind == "task_end":
            result = e.get("result") or {}
            if result.get("machine") == "recover" and result.get("outcome") == "succeeded":
                self.recovered = result
        elif kind == "state":
            src, dst = e.get("from"), e.get("to")
            if self.recovered is not None and dst == "BLOCKED":
                self.violations.append(f"a `recover` succeeded ({self.recovered.get('task')}) "
                                       f"and the world is still BLOCKED: {e}")  # fmt: skip
            self.recovered = None
            if src in LATCHED and self.latched is not None and (src, dst) != ("ERROR", "ESTOPPED"):
                self.violations.append(f"left {src} for {dst} without a reset: {e}")
            if dst in LATCHED:
                self.latched = dst if self.latched != "ESTOPPED" else self.latched
        elif kind == "task_start":
            tid = e.get("task")
            if tid in self.started:
                self.violations.append(f"task id {tid} started twice: {e}")
            self.started.add(tid)
            if self.latched is not None:
                self.violations.append(f"a task started while {self.latched}: {e}")
        elif kind == "restore" and self.latched is not None:
            self.violations.append(f"a restore applied while {self.latched}: {e}")

    def reply(self, op: str, answers: list[dict[str, Any]]) -> None:
        """The answers one command got (all of them, once the query is over)."""
        if len(answers) != 1:
            self.violations.append(f"{op}: {len(answers)} answers (one expected): {answers}")
            return
        answer = answers[0]
        if "internal error" in answer.get("reason", ""):
            self.violations.append(f"{op}: {answer['reason']}")
        if not answer.get("accepted") and not answer.get("reason"):
            self.violations.append(f"{op}: refused without a reason")
        tid = answer.get("task") if op in ("run", "set", "preempt", "recover") else None
        if answer.get("accepted") and tid:
            if tid in self.given:
                self.violations.append(f"task id {tid} given twice")
            self.given.add(tid)

    @staticmethod
    def motion(statuses: list[dict[str, Any]]) -> list[str]:
        """The status stream (all of it so far): no arm motion while latched (per physics
        step, live/motion.py)."""
        found = []
        for run, stop_t in latched_runs(statuses):
            for moving in motion_while_latched(run, stop_t):
                found.append(
                    f"the arm moved while {moving['state']}: {moving['arm_speed']['peak']} rad/s "
                    f"at t {moving['arm_speed']['t0']}..{moving['arm_speed']['t1']} s (stop at "
                    f"{stop_t} s)"
                )
        return found


def latched_runs(statuses: list[dict[str, Any]]) -> list[tuple[list[dict[str, Any]], float]]:
    """Maximal runs of consecutive latched statuses of one stop (a new e-stop or a new error
    starts a new run), each with the simulated time of its stop."""
    runs: list[tuple[list[dict[str, Any]], float]] = []
    ident = None
    for status in statuses:
        state = status.get("state")
        if state not in LATCHED:
            ident = None
            continue
        estop = status.get("last_estop") or {}
        this = (state, estop.get("t") if state == "ESTOPPED" else status.get("error"))
        if this != ident:
            stop_t = estop.get("t") if state == "ESTOPPED" else status.get("sim_time")
            runs.append(([], float(stop_t if stop_t is not None else status["sim_time"])))
            ident = this
        runs[-1][0].append(status)
    return runs


class Driver:
    """Two clients of one session: each sends commands without waiting for the answer
    (several may arrive in one control tick); every answer is kept per query."""

    def __init__(self, server: LiveServer) -> None:
        import zenoh

        from orchestrator.live.protocol import config_for

        self.server = server
        self.z = [zenoh.open(config_for(connect=[server.endpoint])) for _ in range(2)]
        self.owner = [f"owner-{n}-{time.monotonic_ns()}" for n in range(2)]
        self.lock = threading.Lock()
        self.sent: list[tuple[str, list[dict[str, Any]]]] = []
        self.script: list[dict[str, Any]] = []
        self.model = ProtocolModel()
        self.moved: list[str] = []
        with server.lock:
            self._events_seen = self._first_event = len(server.events)
            self._status_from = len(server.statuses)
            self._published_from = len(server.published)
        self._beat_stop = threading.Event()
        self._beats = threading.Thread(target=self._beat, daemon=True)
        self._beats.start()

    def _beat(self) -> None:
        """Client 0 keeps its tasks alive (heartbeats every 50 ms); client 1 only beats when
        the script says so (its tasks may trip the watchdog: ERROR)."""
        while not self._beat_stop.wait(0.05):
            self.z[0].put(key(self.server.name, "clients/heartbeat"), self.owner[0])

    def payload(self, client: int, op: str, name: str) -> str:
        """The JSON of one command of the script."""
        base: dict[str, Any] = {"client": f"c{client}", "owner": self.owner[client]}
        if op in ("run", "preempt"):
            base.update(op="run", preempt=op == "preempt")
        elif op == "set":
            base.update(op="run", machine="reach", set=["target=[0.45, -0.2, 0.5]"])
        elif op in ("snapshot", "restore"):
            base.update(op=op, snapshot=name)
        elif op == "reload":
            base.update(op="reload", machine="pick_place")
        else:
            base.update(op=op)
        return Command.model_validate(base).model_dump_json(exclude_defaults=True)

    def send(self, client: int, op: str, name: str = "m0", delay: float = 0.0) -> None:
        """Send one command (the e-stop on its key, a heartbeat as a put), then wait `delay`."""
        self.script.append({"client": client, "op": op, "name": name, "delay": delay})
        z, session = self.z[client], self.server.name
        if op == "heartbeat":
            z.put(key(session, "clients/heartbeat"), self.owner[client])
        else:
            answers: list[dict[str, Any]] = []
            with self.lock:
                self.sent.append((op, answers))
            if op == "reset":
                self.model.resets_sent += 1

            def take(reply: Any) -> None:
                if reply.ok is not None:
                    with self.lock:
                        answers.append(json.loads(reply.ok.payload.to_string()))

            leaf = "estop" if op == "estop" else "command"
            z.get(key(session, leaf), take, payload=self.payload(client, op, name), timeout=30.0)
        if delay:
            time.sleep(delay)

    def check(self) -> list[str]:
        """Feed the model what was published since the last check; its violations so far."""
        events, statuses = self.server.snapshot_events()
        for e in events[self._events_seen :]:
            self.model.event(e)
        self._events_seen = len(events)
        self.moved = ProtocolModel.motion(statuses[self._status_from :])
        return self.violations

    @property
    def violations(self) -> list[str]:
        return [*self.model.violations, *self.moved]

    def finish(self, quiet_s: float = 0.5, timeout: float = 30.0) -> list[str]:
        """Wait for every answer (and a little more, to see a second one), check everything."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            with self.lock:
                if all(answers for _, answers in self.sent):
                    break
            time.sleep(0.02)
        time.sleep(quiet_s)
        self.check()
        with self.lock:
            for op, answers in self.sent:
                self.model.reply(op, list(answers))
        events, statuses = self.server.snapshot_events()
        STATS["interleavings"] += 1
        STATS["steps"] += len(self.script)
        STATS["answers"] += sum(len(a) for _, a in self.sent)
        STATS["latched runs"] += len(latched_runs(statuses[self._status_from :]))
        STATS["latched statuses"] += sum(
            len(r) for r, _ in latched_runs(statuses[self._status_from :])
        )
        for e in events[self._first_event :]:
            STATS[f"event {e.get('event')}"] += 1
        for s in statuses[self._status_from :]:
            STATS[f"state {s.get('state')}"] += 1
        STATS["violations"] += len(self.violations)
        return self.violations

    def report(self) -> str:
        """The violations, what the session published meanwhile (its events and statuses,
        in short: a timing-dependent finding may not replay), and the script that produced
        them (replayable)."""
        return (
            "protocol violations:\n  " + "\n  ".join(self.violations)
            + "\npublished (events and statuses, in the order received):\n  "
            + "\n  ".join(self.published())
            + "\nreplay: save this script as a file and run "
            "`python -m tests.live_model FILE`:\n" + json.dumps(self.script)
        )  # fmt: skip

    def published(self, last: int = 120) -> list[str]:
        """The last `last` events and statuses since this driver began, one line each: the
        events as sent; a status as its state, simulated time, `arm_speed` window and the
        last e-stop's time."""
        with self.server.lock:
            merged = [*self.server.published[self._published_from :]]
        lines = []
        for kind, msg in merged[-last:]:
            if kind == "events":
                lines.append("event " + json.dumps(msg)[:300])
            else:
                speed = msg.get("arm_speed") or {}
                lines.append(
                    f"status {msg.get('state')} t {msg.get('sim_time')} arm {speed.get('peak')} "
                    f"rad/s {speed.get('t0')}..{speed.get('t1')} estop t "
                    f"{(msg.get('last_estop') or {}).get('t')}"
                )
        return lines

    def close(self) -> None:
        self._beat_stop.set()
        self._beats.join(1.0)
        for z in self.z:
            z.close()


RECOVERS = 3
"""`recover`s `settle` sends at most before it says the session is BLOCKED for good."""


def settle(server: LiveServer, timeout: float = 60.0) -> None:
    """Bring the session back to IDLE between examples: e-stop, reset, and, when the world
    it leaves violates a guard (BLOCKED: an abort's stop may end past a limit), `recover`
    (as docs/live.md says an operator does), then wait. The settling client beats: it owns
    the recovery task it starts."""
    from orchestrator.live.client import Client

    status: dict[str, Any] = {}
    why = f"the session did not come back to IDLE in {timeout} s"
    with server.lock:
        first_event = len(server.events)
    with Client(server.name, [server.endpoint], name="settle", heartbeat_s=0.05) as c:
        c.estop()  # applied at the next tick: IDLE counts only once the latch was seen
        latched, recovering, recovers = False, None, 0
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            status = c.status()
            state, quiet = status["state"], status["task"] is None and not status["queued"]
            ended = (status["last_result"] or {}).get("task") == recovering
            if state in LATCHED:
                latched, recovering = True, None
                c.reset()
            elif latched and quiet and state == "IDLE":
                return
            elif latched and quiet and state == "BLOCKED" and (recovering is None or ended):
                blocked = status["blocked"] or {}
                if not blocked.get("recoverable") or recovers >= RECOVERS:
                    why = (f"the session stays BLOCKED ({recovers} recover sent; "
                           f"recoverable: {blocked.get('recoverable')})")  # fmt: skip
                    break
                reply = c.command("recover")
                recovers += 1
                STATS["settle: recover sent"] += 1
                recovering = reply.task if reply.accepted else None
            time.sleep(0.1)
    events, _ = server.snapshot_events()
    raise AssertionError(
        f"{why}: last status {json.dumps(status)}; events since the e-stop: "
        f"{json.dumps(events[first_event:][-40:])}"
    )


def replay(server: LiveServer, script: list[dict[str, Any]]) -> list[str]:
    """Send `script` (as a failure printed it) to `server`; the model's violations."""
    driver = Driver(server)
    try:
        for step in script:
            driver.send(step["client"], step["op"], step.get("name", "m0"), step["delay"])
            driver.check()
        return driver.finish()
    finally:
        driver.close()


def main() -> None:
    import tempfile

    script = json.loads(Path(sys.argv[1]).read_text())
    server = LiveServer(Path(tempfile.mkdtemp(prefix="replay-")), name="replay", watchdog_s=0.5)
    try:
        violations = replay(server, script)
    finally:
        server.close()
    print("\n".join(violations) or "no violation")
    sys.exit(1 if violations else 0)


if __name__ == "__main__":
    main()
