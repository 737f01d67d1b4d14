"""Shrink a failing variation to a minimal one: the fewest parameters moved from nominal, each
as close to nominal as still fails.

Two passes, each asking `fails` about a round of candidates at once (a backend runs them in
parallel) and keeping the first candidate, in parameter order, that still fails the same way:

1. *Fewer parameters*: each moved parameter put back to nominal, one at a time; repeated
   until no single one can go back.
2. *Closer to nominal*: each remaining number bisected between nominal and its failing
   value (`BISECT_STEPS` halvings, each keeps the half nearer nominal if it still fails); a
   whole number stops when the interval closes.

The same seed runs every candidate, so a candidate differs from the failure only by its values.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from .params import Parameter

__all__ = ["BISECT_STEPS", "Shrunk", "shrink"]

BISECT_STEPS = 6
"""Halvings of the distance to nominal per remaining number (1/64 of the way at the end)."""

FailsMany = Callable[[Sequence[dict[str, Any]]], list[bool]]
"""Runs each candidate (moved path -> value) and says which still fail the same way."""


@dataclass(frozen=True)
class Shrunk:
    """A shrunk failure.

    Attributes:
        values: The minimal variation (moved path -> value).
        runs: Episodes the shrinking ran.
    """

    values: dict[str, Any]
    runs: int


def _closer(p: Parameter, near: Any, far: Any) -> Any:
    """Half way from `near` (nominal side) to `far` (failing side); None: no value between."""
    if p.integer:
        step = int((int(far) - int(near)) / 2)  # towards zero: never past `far`
        return None if step == 0 else int(near) + step
    mid = round((float(near) + float(far)) / 2.0, 6)
    return None if mid in (float(near), float(far)) else mid


def shrink(
    values: Mapping[str, Any],
    params: Mapping[str, Parameter],
    fails: FailsMany,
    bisect_steps: int = BISECT_STEPS,
) -> Shrunk:
    """The minimal variation of a failing one.

    Args:
        values: The failing variation (moved path -> value).
        params: Every parameter by path (their nominal values and ranges).
        fails: Runs candidates; True for each that still fails the same way.
        bisect_steps: Halvings per remaining number.
    """
    current = dict(values)
    runs = 0
    while current:  # pass 1: put parameters back to nominal, one at a time (all: the seed
        # fails at nominal too, an empty variation)
        candidates = [{q: v for q, v in current.items() if q != p} for p in current]
        verdicts = fails(candidates)
        runs += len(candidates)
        kept = next((c for c, bad in zip(candidates, verdicts, strict=True) if bad), None)
        if kept is None:
            break
        current = kept
    for path in list(current):  # pass 2: each number as close to nominal as still fails
        p = params[path]
        if p.choices:
            continue
        near, far = p.nominal, current[path]
        for _ in range(bisect_steps):
            mid = _closer(p, near, far)
            if mid is None:
                break
            (bad,) = fails([{**current, path: mid}])
            runs += 1
            if bad:
                far = mid
            else:
                near = mid
        current[path] = far
    return Shrunk(current, runs)
