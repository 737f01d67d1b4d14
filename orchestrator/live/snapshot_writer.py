"""A live session's snapshots, written off the control loop, within a cap on count and bytes.

Taking a snapshot must not hold up the control loop (an e-stop behind a burst of `snapshot`
commands is applied at the start of the next tick, not after the burst is written). The loop
only *captures* the state: at the start of a control tick it forks the process (`os.fork`,
a few milliseconds: the child's memory is a copy-on-write image of the session as it is
between two ticks, so nothing the loop does afterwards can reach it). The child serializes,
compresses, signs and writes the file (live/snapshots.py `write_session`) and reports its
size or the error on a pipe; a reaper thread of the session waits for it and publishes the
`snapshot` (or `snapshot_failed`) event; the child runs at a low CPU priority
(`WRITER_NICE`), so on a loaded machine the control loop is scheduled first. At most
`MAX_WRITERS` children write at once and at most one is forked per control tick; further
snapshots wait their turn in order (each is captured at the tick its writer is forked). A
child that takes longer than `WRITE_TIMEOUT_S` is killed (`snapshot_failed`).

The cap: a session writes at most `max_count` snapshots (accepted ones count from the moment
they are accepted) and `max_bytes` bytes in all (written ones; a snapshot is refused when the
bytes written and the size of the last one would pass it). A refusal names the cap and the
`serve` option that sets it. Where `os.fork` does not exist the snapshot is written on the
loop, as before (no such platform is supported for live sessions today).
"""

from __future__ import annotations

import json
import os
import select
import signal
import threading
import time
from collections import deque
from collections.abc import Callable
from pathlib import Path
from typing import Any

__all__ = [
    "MAX_WRITERS",
    "SNAPSHOT_BYTES",
    "SNAPSHOT_COUNT",
    "WRITE_TIMEOUT_S",
    "WRITER_NICE",
    "SnapshotWriter",
]

SNAPSHOT_COUNT = 100
"""Snapshots a session writes at most by default (`serve --snapshot-count`)."""
SNAPSHOT_BYTES = 2 * 2**30
"""Bytes of snapshots a session writes at most by default (`serve --snapshot-mb`: 2048)."""
MAX_WRITERS = 2
"""Snapshot writers (child processes) at once."""
WRITE_TIMEOUT_S = 120.0
"""Longest a writer may take before it is killed [s]."""
WRITER_NICE = 15
"""How much a writer lowers its CPU priority (`os.nice`): it yields to the control loop."""

Capture = Callable[[Path], int]
"""Writes the session's state, as it is now, to the path; returns the file's size."""
Publish = Callable[[str, dict[str, Any]], None]


def _mb(n: int) -> str:
    return f"{n / 2**20:.1f} MB"


class SnapshotWriter:
    """The snapshots of one session: admission under the cap, a fork per snapshot, reaping.

    Args:
        capture: Writes the session's state to a path (runs in the child).
        publish: The session's `publish` (events).
        max_count: Snapshots the session may write in all.
        max_bytes: Bytes the session may write in all.
    """

    def __init__(
        self,
        capture: Capture,
        publish: Callable[[], Publish],
        max_count: int = SNAPSHOT_COUNT,
        max_bytes: int = SNAPSHOT_BYTES,
    ) -> None:
        self.capture, self._publish = capture, publish
        self.max_count, self.max_bytes = max_count, max_bytes
        self._lock = threading.Lock()
        self.accepted = 0
        """Snapshots accepted so far (pending, being written, written or failed)."""
        self.written_bytes = 0
        self._last_size = 0
        self.pending: deque[Path] = deque()
        """Applied snapshots waiting for a writer (the loop's; in order)."""
        self._writing: dict[Path, threading.Thread] = {}
        self._done = threading.Condition(self._lock)

    # -- any thread -----------------------------------------------------------------------
    def admit(self) -> str | None:
        """Reserve one snapshot under the cap (None), or say which cap refuses it."""
        with self._lock:
            if self.accepted >= self.max_count:
                return (
                    f"snapshot refused: this session's cap of {self.max_count} snapshots is "
                    "reached (serve --snapshot-count N; delete none of them: the cap counts "
                    "what the session wrote)"
                )
            if self.written_bytes + self._last_size > self.max_bytes:
                return (
                    f"snapshot refused: this session's cap of {_mb(self.max_bytes)} of "
                    f"snapshots would be passed ({_mb(self.written_bytes)} written, the last "
                    f"one {_mb(self._last_size)}; serve --snapshot-mb N)"
                )
            self.accepted += 1
        return None

    def busy_with(self, path: Path) -> bool:
        """True while a snapshot to `path` waits for its writer or is being written."""
        with self._lock:
            return path in self._writing or path in self.pending

    def wait_for(self, path: Path, timeout: float) -> bool:
        """Wait until no snapshot to `path` is pending or being written (True), or `timeout`."""
        deadline = time.monotonic() + timeout
        while self.busy_with(path):
            left = deadline - time.monotonic()
            if left <= 0:
                return False
            with self._done:
                self._done.wait(min(left, 0.05))
        return True

    # -- the loop ---------------------------------------------------------------------------
    def add(self, path: Path) -> None:
        """An applied `snapshot` command: written as soon as a writer is free."""
        with self._lock:
            self.pending.append(path)

    def tick(self, info: Callable[[], dict[str, Any]]) -> None:
        """Start at most one writer (the loop, at the start of a control tick); `info` says
        what is captured (simulated time, tick: in the `snapshot` event)."""
        with self._lock:
            if not self.pending or len(self._writing) >= MAX_WRITERS:
                return
            path = self.pending.popleft()
        captured = info()
        if not hasattr(os, "fork"):
            self._inline(path, captured)
            return
        read_fd, write_fd = os.pipe()
        pid = os.fork()
        if pid == 0:  # the child: a copy of the session between two ticks
            os.close(read_fd)
            self._child(path, write_fd)
        os.close(write_fd)
        reaper = threading.Thread(target=self._reap, args=(pid, read_fd, path, captured),
                                  name="orchestrator-snapshot-reaper", daemon=True)  # fmt: skip
        with self._lock:
            self._writing[path] = reaper
        reaper.start()

    def close(self, timeout: float = 30.0) -> None:
        """At shutdown: writers in flight finish (up to `timeout`); waiting ones are dropped."""
        with self._lock:
            dropped, self.pending = list(self.pending), deque()
            writers = list(self._writing.values())
        for path in dropped:
            self._publish()("events", {"event": "snapshot_failed", "snapshot": str(path),
                                       "reason": "the session shut down first"})  # fmt: skip
        deadline = time.monotonic() + timeout
        for writer in writers:
            writer.join(max(0.0, deadline - time.monotonic()))

    # -- the writers ------------------------------------------------------------------------
    def _child(self, path: Path, write_fd: int) -> None:
        """Write the snapshot and report on the pipe; never returns (`os._exit`)."""
        code = 0
        try:
            signal.signal(signal.SIGINT, signal.SIG_DFL)
            signal.signal(signal.SIGTERM, signal.SIG_DFL)
            os.nice(WRITER_NICE)  # the control loop, not the writer, gets the CPU first
            msg: dict[str, Any] = {"bytes": self.capture(path)}
        except BaseException as exc:  # everything is reported: the parent publishes it
            msg, code = {"error": f"{type(exc).__name__}: {exc}"[:500]}, 1
        try:
            os.write(write_fd, json.dumps(msg).encode())
        finally:
            os._exit(code)

    def _reap(self, pid: int, read_fd: int, path: Path, info: dict[str, Any]) -> None:
        chunks: list[bytes] = []
        deadline = time.monotonic() + WRITE_TIMEOUT_S
        try:
            while True:
                left = deadline - time.monotonic()
                ready, _, _ = select.select([read_fd], [], [], max(0.0, left))
                if not ready:
                    os.kill(pid, signal.SIGKILL)
                    chunks = [json.dumps({"error": f"not written in {WRITE_TIMEOUT_S} s: "
                                          "the writer was killed"}).encode()]  # fmt: skip
                    break
                chunk = os.read(read_fd, 65536)
                if not chunk:
                    break
                chunks.append(chunk)
        finally:
            os.close(read_fd)
            os.waitpid(pid, 0)
        try:
            msg = json.loads(b"".join(chunks) or b"{}")
        except ValueError:
            msg = {}
        self._finish(path, info, msg)

    def _inline(self, path: Path, info: dict[str, Any]) -> None:
        try:
            msg: dict[str, Any] = {"bytes": self.capture(path)}
        except Exception as exc:
            msg = {"error": f"{type(exc).__name__}: {exc}"[:500]}
        with self._lock:
            self._writing[path] = threading.current_thread()
        self._finish(path, info, msg)

    def _finish(self, path: Path, info: dict[str, Any], msg: dict[str, Any]) -> None:
        size = msg.get("bytes")
        with self._lock:
            self._writing.pop(path, None)
            if isinstance(size, int):
                self.written_bytes += size
                self._last_size = size
            self._done.notify_all()
        if isinstance(size, int):
            event = {"event": "snapshot", "snapshot": str(path), "bytes": size, **info}
        else:
            why = msg.get("error") or "the writer ended without a word (killed?)"
            event = {"event": "snapshot_failed", "snapshot": str(path), "reason": why}
        self._publish()("events", event)
