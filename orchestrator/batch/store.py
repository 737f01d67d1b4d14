"""`DIR/results.jsonl`: one JSON line per finished episode, written the moment it ends.

Each line goes to the file in a single unbuffered `write`, so a crash of the batch (even a
SIGKILL) loses no finished episode; at worst the last line is torn, and `load` cuts it off.
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

from ..engine.strict_json import dumps
from .exceptions import BatchError

__all__ = ["RESULTS", "ResultsStore"]

RESULTS = "results.jsonl"


class ResultsStore:
    """The results file of one batch directory.

    Args:
        out_dir: The batch directory; created on `open`.
    """

    def __init__(self, out_dir: Path) -> None:
        self.path = Path(out_dir) / RESULTS
        self._fd: int | None = None

    def load(self, repair: bool = False) -> dict[int, dict[str, Any]]:
        """The finished episodes by seed (the first line of a seed wins).

        Args:
            repair: Truncate a torn last line (one without its newline, or not valid JSON)
                so that appending continues on a line boundary.

        Raises:
            BatchError: A line other than the last is not valid JSON.
        """
        if not self.path.is_file():
            return {}
        raw = self.path.read_bytes()
        lines = raw.split(b"\n")
        tail = lines.pop()  # b"" when the file ends with a newline, else a torn line
        keep = len(raw) - len(tail)
        out: dict[int, dict[str, Any]] = {}
        for i, text in enumerate(lines):
            if not text.strip():
                continue
            try:
                line = json.loads(text)
                seed = int(line["seed"])
            except (ValueError, KeyError, TypeError):
                if i == len(lines) - 1 and not tail:
                    keep -= len(text) + 1  # a complete but garbled last line: torn as well
                    break
                raise BatchError(
                    f"{self.path}:{i + 1}: not a result line ({text[:60]!r}); the file was "
                    "edited or corrupted: fix or remove that line, or use another --out"
                ) from None
            out.setdefault(seed, line)
        if repair and keep < len(raw):
            with self.path.open("r+b") as f:
                f.truncate(keep)
        return out

    def open(self) -> None:
        """Open for appending (creating the directory and the file)."""
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._fd = os.open(self.path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)

    def append(self, line: dict[str, Any]) -> None:
        """Write one episode's line now (one `write` call, no user-space buffer)."""
        if self._fd is None:
            raise RuntimeError("ResultsStore.append before open()")
        data = (dumps(line) + "\n").encode()
        view = memoryview(data)
        while view:
            view = view[os.write(self._fd, view) :]

    def close(self) -> None:
        """Flush to disk and close."""
        if self._fd is not None:
            os.fsync(self._fd)
            os.close(self._fd)
            self._fd = None
