"""`orchestrator watch`: a live table of a session's status; warns when heartbeats stop."""

from __future__ import annotations

import json
import threading
import time
from typing import Any

from rich.console import Console
from rich.live import Live
from rich.markup import escape
from rich.table import Table

from .access import Credentials
from .protocol import DEFAULT_ENDPOINT, config_for, key

__all__ = ["HEARTBEAT_LOST_S", "render", "watch"]

HEARTBEAT_LOST_S = 0.5
"""No session heartbeat for this long (wall time) and the view says so [s]."""
_STYLE = {"IDLE": "green", "MOVING": "cyan", "GRASPING": "cyan", "PAUSED": "yellow",
          "BLOCKED": "bold yellow", "ESTOPPED": "bold red", "ERROR": "bold red"}  # fmt: skip


def render(status: dict[str, Any] | None, silent_s: float | None, name: str) -> Table:
    """The table for one status message (None: nothing heard yet)."""
    table = Table(title=f"session {name}", show_header=False, box=None, pad_edge=False)
    table.add_column(style="bold")
    table.add_column()
    if silent_s is None or silent_s > HEARTBEAT_LOST_S:
        heard = "never" if silent_s is None else f"{silent_s:.1f} s ago"
        table.add_row("heartbeat", f"[bold red]LOST[/] (last {heard})")
    if status is None:
        return table
    state = status["state"]
    table.add_row("state", f"[{_STYLE.get(state, '')}]{state}[/]")
    task = status.get("task")
    table.add_row(
        "task", "-" if task is None else f"#{task['id']} {task['machine']}  {task['leaf']}"
    )
    table.add_row("queued", str(status.get("queued", 0)))
    last = status.get("last_result")
    if last:
        reason = f" ({last['reason']['guard']})" if last.get("reason") else ""
        table.add_row(
            "last result", f"#{last['task']} {last['machine']}: {last['outcome']}{reason}"
        )
    blocked = status.get("blocked")
    if blocked:  # the guard the idle world violates: `recover` gets out
        why = escape(f"{blocked['guard']}: {blocked['message']}")
        table.add_row("blocked", f"[yellow]{why}[/] (send recover)")
    if status.get("error"):
        table.add_row("error", f"[red]{status['error']}[/]")
    rt = status.get("realtime_factor")
    table.add_row(
        "time",
        f"sim {status['sim_time']:.2f} s, wall {status['wall_time']:.2f} s"
        + (f", {rt:.3f}x real time" if rt is not None else ""),
    )
    table.add_row("tcp [m]", str(status.get("tcp")))
    return table


def watch(
    name: str,
    connect: list[str] | None = None,
    duration_s: float | None = None,
    console: Console | None = None,
    credentials: Credentials | None = None,
) -> int:
    """Show the live table until Ctrl-C (or `duration_s`). Returns 0, or 1 if the session's
    heartbeat was lost when the view ended. A viewer's credentials are enough."""
    import zenoh

    endpoints = list(connect or [DEFAULT_ENDPOINT])
    z = zenoh.open(config_for(connect=endpoints, credentials=credentials))
    latest: dict[str, Any] = {"status": None, "beat": None}
    lock = threading.Lock()

    def on_status(sample: Any) -> None:
        with lock:
            latest["status"] = json.loads(sample.payload.to_string())

    def on_beat(sample: Any) -> None:
        with lock:
            latest["beat"] = time.monotonic()

    subs = [z.declare_subscriber(key(name, "status"), on_status),
            z.declare_subscriber(key(name, "heartbeat"), on_beat)]  # fmt: skip
    end = None if duration_s is None else time.monotonic() + duration_s
    silent: float | None = None
    try:
        with Live(render(None, None, name), console=console, refresh_per_second=10) as live:
            while end is None or time.monotonic() < end:
                time.sleep(0.1)
                with lock:
                    beat, status = latest["beat"], latest["status"]
                silent = None if beat is None else time.monotonic() - beat
                live.update(render(status, silent, name))
    except KeyboardInterrupt:
        pass
    finally:
        for sub in subs:
            sub.undeclare()
        z.close()
    return 0 if silent is not None and silent <= HEARTBEAT_LOST_S else 1
