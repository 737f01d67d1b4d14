"""Stopping a run at a break point: find the control tick it happens in, then stop before it.

A state is entered inside a control tick (after the previous state's last step), and a guard
fires inside one (on a physics step), so a run cannot stop *at* the entry and resume from
there. It stops at the start of that tick instead: `find_stop` runs the episode until the
break point happens and notes the tick; `run_to` runs a fresh copy of the same run (the run is
deterministic) and stops before that tick. The resumed run enters the state as the first thing
it does. A time break point needs no second run: the tick boundary it names is where the
first one stops.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

from ...language.machine import SAFE_STOP
from ..result import RunResult
from ..runner import RunState, drive
from .breaks import ANY_GUARD, BreakPoint

__all__ = ["EntryLog", "Stop", "find_stop", "last_entry_stop", "run_to"]

_EPS = 1e-9


@dataclass(frozen=True)
class Stop:
    """Where a run stops for a snapshot.

    Attributes:
        tick: Stop before the control tick that starts with `ctx.tick == tick`.
        before_start: Stop before the machine's initial state is entered (then `tick` is 0).
        reason: What happens in that tick, said for the user (`entry of PICK.GRASP`).
        option: The option that asked for it (`--break GRASP`), or how it was chosen.
    """

    tick: int
    before_start: bool
    reason: str
    option: str

    def header(self) -> dict[str, Any]:
        """The snapshot header's `break` entry."""
        return {
            "tick": self.tick,
            "before_start": self.before_start,
            "reason": self.reason,
            "option": self.option,
        }

    def reached(self, run: RunState) -> bool:
        """`run` is where this stop is (asked before the start and before every tick)."""
        if self.before_start:
            return not run.started
        return run.started and run.ctx.tick == self.tick


class _Finder:
    """Listens to a run's state entries for the first break point that happens."""

    def __init__(self, run: RunState, points: Sequence[BreakPoint]) -> None:
        self.run, self.points = run, list(points)
        self.counts = [0] * len(self.points)
        self.hit: Stop | None = None

    def __call__(self, path: str, retry: int | None) -> None:
        if self.hit is not None:
            return
        run = self.run
        violation = run.executor.violation
        for i, point in enumerate(self.points):
            if point.matches(path):
                self.counts[i] += 1
                if self.counts[i] == point.nth:
                    what = "retry" if retry else "entry"
                    self._stop(point, f"{what} of {path}")
                    return
            elif point.guard is not None and path == SAFE_STOP and violation is not None:
                if point.guard in (ANY_GUARD, violation.guard):
                    self._stop(point, f"abort by {violation.guard}: {violation.message}")
                    return

    def _stop(self, point: BreakPoint, reason: str) -> None:
        run = self.run
        self.hit = Stop(run.ctx.tick, not run.started, reason, point.option)


def find_stop(run: RunState, points: Sequence[BreakPoint]) -> tuple[Stop | None, RunResult | None]:
    """Run `run` until the first of `points` happens.

    Returns:
        (the stop, None) — `run` is then somewhere past it unless the stop is a time break
        point (`run` is exactly there: `Stop.reached(run)`); or (None, the run's result) if
        it ended without reaching any.
    """
    finder = _Finder(run, points)
    at_t = min((p.at_t for p in points if p.at_t is not None), default=None)
    time_point = next((p for p in points if p.at_t == at_t), None) if at_t is not None else None

    def until(r: RunState) -> bool:
        if finder.hit is not None:
            return True
        if time_point is not None and r.started and r.ctx.t >= at_t - _EPS:  # type: ignore[operator]
            finder.hit = Stop(r.ctx.tick, False, f"t={r.ctx.t:.6g} s", time_point.option)
            return True
        return False

    run.executor.entry_listeners.append(finder)
    try:
        result = drive(run, until=until)
    finally:
        run.executor.entry_listeners.remove(finder)
    return (finder.hit, None) if result is None else (None, result)


def run_to(run: RunState, stop: Stop) -> bool:
    """Run a fresh `run` (built like the one `find_stop` ran) up to `stop`; False if it ended
    first (it would not: the run is deterministic)."""
    return drive(run, until=stop.reached) is None


@dataclass
class EntryLog:
    """Every state entry of a run, for `last_entry_stop` (attach it to
    `Executor.entry_listeners`).

    Attributes:
        run: The run listened to.
        entries: (tick, before start, path, retry number or None) of each entry, in order.
    """

    run: RunState
    entries: list[tuple[int, bool, str, int | None]] = field(default_factory=list)

    def __call__(self, path: str, retry: int | None) -> None:
        self.entries.append((self.run.ctx.tick, not self.run.started, path, retry))


def last_entry_stop(log: EntryLog, final_states: Callable[[str], bool]) -> Stop | None:
    """The start of the tick of the last state entry before the run failed: not an entry of
    a final state, nor one after a guard fired (the safe stop, the `on_abort` response)."""
    ex = log.run.executor
    cut = len(log.entries)
    if ex.violation is not None:
        cut = next((i for i, e in enumerate(log.entries) if e[2] == SAFE_STOP), cut)
    for tick, before_start, path, _ in reversed(log.entries[:cut]):
        if not final_states(path):
            return Stop(tick, before_start, f"entry of {path}", "--snapshot-on-failure")
    return None
