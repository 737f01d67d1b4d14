"""Run events (transitions, outcomes, retries, guard violations, ...) as TextLog columns."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import rerun as rr
from rerun.chunk import Chunk

from .paths import EVENTS, part
from .timeline import time_columns

if TYPE_CHECKING:
    from ..engine.context import Event

__all__ = ["EventLog", "event_text", "text_log_level"]

_LEVELS = {
    "CRITICAL": "CRITICAL",
    "ERROR": "ERROR",
    "WARN": "WARN",
    "WARNING": "WARN",
    "INFO": "INFO",
    "DEBUG": "DEBUG",
    "TRACE": "TRACE",
}
"""Event levels -> Rerun's TextLog levels (`rr.TextLogLevel`)."""


def text_log_level(level: str) -> str:
    """Rerun's TextLog level for an event level (`WARNING` -> `WARN`; unknown -> `INFO`)."""
    return _LEVELS.get(level.upper(), "INFO")


def event_text(event: Event) -> str:
    """One line for the log. A violation names its guard, the value and the limit."""
    data = event.data or {}
    if event.kind == "violation" and "guard" in data:
        return (
            f"{event.message} (guard {data['guard']}, value {data.get('value')},"
            f" limit {data.get('limit')})"
        )
    return event.message


class EventLog:
    """Buffers events per kind; each kind is sent to `events/<kind>` as one TextLog column."""

    def __init__(self) -> None:
        self._rows: dict[str, list[tuple[int, float, str, str]]] = {}

    def add(self, tick: int, event: Event) -> None:
        """Buffer `event`, which happened during control tick `tick`."""
        self.add_text(tick, event.t, event.kind, event_text(event), event.level)

    def add_text(self, tick: int, t_s: float, kind: str, text: str, level: str = "INFO") -> None:
        """Buffer a line of kind `kind` at control tick `tick`, simulated time `t_s` [s]."""
        self._rows.setdefault(kind, []).append((tick, t_s, text, text_log_level(level)))

    def chunks(self) -> list[Chunk]:
        """The buffered lines, one chunk per kind; the buffer is emptied."""
        out = []
        for kind, rows in self._rows.items():
            if not rows:
                continue
            ticks, t_s, texts, levels = zip(*rows, strict=True)
            out.append(
                Chunk.from_columns(
                    f"{EVENTS}/{part(kind)}",
                    indexes=time_columns(np.array(ticks), np.array(t_s)),
                    columns=rr.TextLog.columns(text=list(texts), level=list(levels)),
                )
            )
        self._rows = {}
        return out
