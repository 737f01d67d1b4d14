"""`DIR/.lock`: one batch at a time per output directory.

Two batches writing the same `results.jsonl` would both run every seed and interleave their
`.rrd` files. The lock file holds the owner's pid and host; a second batch on the directory
exits naming the owner, and a lock left by a process that no longer exists (a SIGKILL, a
crash) is taken over.
"""

from __future__ import annotations

import json
import os
import socket
import time
from pathlib import Path

from .exceptions import BatchError

__all__ = ["LOCK", "BatchLock"]

LOCK = ".lock"


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True  # exists, owned by someone else
    return True


class BatchLock:
    """The lock of one batch directory; use as a context manager.

    Args:
        out_dir: The batch directory (created if missing).
    """

    def __init__(self, out_dir: Path) -> None:
        self.path = Path(out_dir) / LOCK
        self.held = False

    def acquire(self) -> None:
        """Take the lock, or take over a stale one.

        Raises:
            BatchError: Another live batch holds it (the message names its pid and host).
        """
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise BatchError(
                f"cannot use {self.path.parent} as the batch directory: {exc.strerror}"
            ) from None
        me = {"pid": os.getpid(), "host": socket.gethostname(), "since": time.time()}
        for _ in range(3):
            try:
                fd = os.open(self.path, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
            except PermissionError:
                raise BatchError(f"cannot write in {self.path.parent}: permission denied") from None
            except FileExistsError:
                holder = self._holder()
                if holder is not None and self._live(holder):
                    since = time.strftime("%Y-%m-%d %H:%M:%S", time.localtime(holder["since"]))
                    raise BatchError(
                        f"{self.path.parent} is in use by another batch (pid {holder['pid']} on "
                        f"{holder['host']}, since {since}): wait for it to finish or choose "
                        f"another --out (if that process is gone, remove {self.path})"
                    ) from None
                self.path.unlink(missing_ok=True)  # stale: its owner is gone
                continue
            with os.fdopen(fd, "w") as f:
                f.write(json.dumps(me) + "\n")
            self.held = True
            return
        raise BatchError(f"cannot take the lock {self.path}: another batch keeps taking it")

    def _holder(self) -> dict | None:
        try:
            data = json.loads(self.path.read_text())
            return {"pid": int(data["pid"]), "host": str(data["host"]), "since": data["since"]}
        except (OSError, ValueError, KeyError, TypeError):
            return None  # unreadable or half-written: treat as stale

    @staticmethod
    def _live(holder: dict) -> bool:
        if holder["host"] != socket.gethostname():
            return True  # cannot check a process on another machine: assume it runs
        return _alive(holder["pid"])

    def release(self) -> None:
        """Remove the lock if this process holds it."""
        if self.held:
            holder = self._holder()
            if holder is not None and holder["pid"] == os.getpid():
                self.path.unlink(missing_ok=True)
            self.held = False

    def __enter__(self) -> BatchLock:
        self.acquire()
        return self

    def __exit__(self, *exc: object) -> None:
        self.release()
