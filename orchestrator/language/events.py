"""Events a scenario sends into a run: `events: [{at: 1.5, event: pause}]`.

An event is a name: a built-in one every machine has (`estop`, `pause`, `resume`) or one the
machine declares in its `events:` (event -> state it preempts into). On the command line,
`--event T:NAME` adds one, e.g. `--event 1.5:estop`, `--event 1.0:pause --event 2.0:resume`.
"""

from __future__ import annotations

import math
from typing import Any

from pydantic import BaseModel, ConfigDict, Field, NonNegativeFloat

from .diagnostics import Diagnostic
from .loading import MachineNode
from .machine import BUILTIN_EVENTS
from .yamlio import SourceMap

__all__ = ["ScheduledEvent", "check_events", "machine_events", "parse_event_spec"]


class ScheduledEvent(BaseModel):
    """One event sent at a simulated time."""

    model_config = ConfigDict(defer_build=True, extra="forbid", allow_inf_nan=False)

    at: NonNegativeFloat = Field(le=1e6, description="Simulated time the event arrives [s].")
    event: str = Field(
        description="Event name: estop, pause, resume, or one of the machine's `events:`."
    )


def machine_events(machine: MachineNode) -> tuple[str, ...]:
    """Every event `machine` understands: the built-in ones, then its own."""
    return (*BUILTIN_EVENTS, *machine.events)


def parse_event_spec(text: str) -> dict[str, Any] | Diagnostic:
    """`T:NAME` -> the raw mapping of an `events:` entry (`1.5:pause` -> at 1.5, pause)."""

    def bad(message: str) -> Diagnostic:
        return Diagnostic("<--event>", 0, 0, text[:80], message)

    at, sep, name = text.partition(":")
    if not sep or not at.strip() or not name.strip():
        return bad("expected T:NAME, a simulated time [s] and an event, e.g. 1.5:estop")
    try:
        t = float(at)
    except ValueError:
        return bad(f"time {at.strip()!r} is not a number of seconds (e.g. 1.5:pause)")
    if not math.isfinite(t) or t < 0.0:
        return bad(f"time {at.strip()!r} must be a finite, non-negative number of seconds")
    return {"at": t, "event": name.strip()}


def check_events(
    machine: MachineNode, events: list[ScheduledEvent], source: SourceMap
) -> list[Diagnostic]:
    """Every scheduled event is one the machine understands."""
    valid = machine_events(machine)
    return [
        source.diag(
            ("events", i, "event"),
            f"machine {machine.name!r} has no event {ev.event!r}",
            valid,
        )
        for i, ev in enumerate(events)
        if ev.event not in valid
    ]
