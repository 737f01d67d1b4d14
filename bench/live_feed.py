"""What the live benches of issue 39 share (bench/live_latch.py, bench/live_snapshot_burst.py):
a `serve pick_place --speed 1` subprocess on 127.0.0.1 with its snapshots in a fresh folder,
a subscriber to what it publishes, and the JSON the bench prints.

    with LiveBench("latch", "--snapshot-count", "40") as bench:
        c = bench.served.client
        ...
        events, statuses, beats = bench.feed()
"""

from __future__ import annotations

import json
import os
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from orchestrator.live.protocol import config_for, key  # noqa: E402
from tests.live_attacks import Served  # noqa: E402

__all__ = ["LiveBench", "emit"]


class LiveBench:
    """A served session and its feed: every `events` and `status` message it publishes, and
    the arrival time of each of its heartbeats (perf_counter) [s].

    Args:
        name: The session's name (and the prefix of its snapshot folder).
        serve_args: More `serve` options (after `--speed 1 --watchdog 0 --snapshots DIR`).
    """

    def __init__(self, name: str, *serve_args: str) -> None:
        import zenoh

        self.folder = Path(tempfile.mkdtemp(prefix=f"{name}-"))
        os.environ.setdefault("XDG_CONFIG_HOME", str(self.folder / "config"))
        self.served = Served(name, "--speed", "1", "--watchdog", "0",
                             "--snapshots", str(self.folder), *serve_args)  # fmt: skip
        self.z = zenoh.open(config_for(connect=[self.served.endpoint]))
        self.lock = threading.Lock()
        self.events: list[dict[str, Any]] = []
        self.statuses: list[dict[str, Any]] = []
        self.beats: list[float] = []
        self._subs = [self.z.declare_subscriber(key(name, leaf), self._take(leaf))
                      for leaf in ("events", "status", "heartbeat")]  # fmt: skip
        time.sleep(0.3)  # the subscriptions reach the session

    def _take(self, leaf: str) -> Any:
        def take(sample: Any) -> None:
            with self.lock:
                if leaf == "heartbeat":
                    self.beats.append(time.perf_counter())
                else:
                    msg = json.loads(sample.payload.to_string())
                    (self.events if leaf == "events" else self.statuses).append(msg)

        return take

    def clear(self) -> None:
        """Forget what was received so far (a trial starts)."""
        with self.lock:
            self.events.clear(), self.statuses.clear(), self.beats.clear()

    def feed(self) -> tuple[list[dict[str, Any]], list[dict[str, Any]], list[float]]:
        """Copies of the events, statuses and heartbeat arrivals received so far."""
        with self.lock:
            return list(self.events), list(self.statuses), list(self.beats)

    def close(self) -> None:
        for sub in self._subs:
            sub.undeclare()
        self.z.close()
        self.served.close()

    def __enter__(self) -> LiveBench:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def emit(out: dict[str, Any], path: Path | None) -> None:
    """Print the bench's figures as JSON (and write them to `path`), with the host's load."""
    out = {**out, "load_avg_1min": round(os.getloadavg()[0], 2), "cpus": os.cpu_count()}
    text = json.dumps(out, indent=2)
    print(text)
    if path is not None:
        path.write_text(text + "\n")
