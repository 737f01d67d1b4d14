"""Every active guard checked every physics step, at the cost of one test of their envelopes.

A guard's `check` is exact but it is Python: ten guards checked one after another cost about
as much as everything else the framework adds to a physics step. Almost always every value is
far inside its limit. So each guard may declare an *envelope* (`Guard.envelope`): bounds on the
raw readings it watches (views into MjData, the controller's output, its own state) inside
which its `check` certainly returns None and changes nothing. `GuardBank` gathers the envelopes
of all active guards once, when the active set changes, and every physics step `inside()`

1. compares the views that must read zero (contact counts, fault flags) with zero bytes
   (`tobytes()`, one memcmp each; a NaN or a -0.0 is not zero there),
2. reads each bounded view once (one `tolist()` per distinct view) and tests all bounds with
   two C-level passes (`all(map(le, ...))`), the pairs that must read equal with one
   comparison each, and the scalars (the wrist force) with one comparison each;

only if a value left the envelope (or a NaN appeared, which no bound admits) does `check` run
every active guard's full `check` in priority order, exactly as if there were no envelope.

Guards without an envelope are checked in full every step. Nothing changes what fires or when:
inside the envelope no guard could have fired; outside it the guards run as they always did,
so the violation, its message and the step it fires on are the same (tests/test_guard_bank.py).

The envelope test is Python only: a compiled twin of it measured no difference a run could
see (bench/guards_envelope.py, BENCHMARKS.md "Guards: one definition"), so there is one.
"""

from __future__ import annotations

import operator
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from .base import Guard, Violation

try:
    from numpy.lib.array_utils import byte_bounds
except ImportError:  # numpy < 2
    from numpy import byte_bounds  # type: ignore[attr-defined,no-redef]

if TYPE_CHECKING:
    from ..engine.context import Context

__all__ = ["GuardBank"]

_le = operator.le


def _origin(view: np.ndarray) -> tuple[np.ndarray, int]:
    """The array `view`'s memory belongs to and the element where `view` starts in it (a view
    that owns its memory: itself, 0). Two views of one array are compared by this, never by
    where the memory lies."""
    base = view.base if isinstance(view.base, np.ndarray) else view
    start = (byte_bounds(view)[0] - byte_bounds(base)[0]) // view.itemsize
    return base, int(start)


@dataclass
class _Watched:
    """One watched 1-D view, the bounds on each of its elements, and where it lies in its
    array (`base`, first element `start`, element step `step`)."""

    view: np.ndarray
    lo: list[float]
    hi: list[float]
    base: np.ndarray
    start: int
    step: int

    @classmethod
    def of(cls, view: np.ndarray, lo: list[float], hi: list[float]) -> _Watched:
        if view.ndim != 1:
            raise ValueError(f"an envelope view must be 1-D, got shape {view.shape}")
        base, start = _origin(view)
        return cls(view, lo, hi, base, start, view.strides[0] // view.itemsize)

    @property
    def key(self) -> tuple[int, int, int, int]:
        """The same memory, element for element (the base is kept alive by the view)."""
        return (id(self.base), self.start, len(self.view), self.step)

    def covers(self, other: _Watched) -> bool:
        """Every element of `other` is one of this view's (both contiguous)."""
        return (
            self.base is other.base
            and self.step == other.step == 1
            and self.start <= other.start
            and other.start + len(other.view) <= self.start + len(self.view)
        )


def _merged(watched: list[_Watched]) -> list[_Watched]:
    """Contiguous views of one contiguous 1-D array that follow each other, as one view (one
    `tolist()` a step instead of several): e.g. the arm's joints and the fingers' in `qpos`."""
    out: list[_Watched] = []
    for w in sorted(watched, key=lambda w: (id(w.base), w.start)):
        last = out[-1] if out else None
        base = w.base
        if (
            last is not None
            and last.base is base
            and base.ndim == 1
            and base.flags.c_contiguous
            and w.step == last.step == 1
            and last.start + len(last.view) == w.start
        ):
            view = base[last.start : w.start + len(w.view)]
            out[-1] = _Watched(view, last.lo + w.lo, last.hi + w.hi, base, last.start, 1)
        else:
            out.append(w)
    return out


class GuardBank:
    """The active guards, in priority order, checked as one (see the module docstring).

    Args:
        guards: The active guards, highest priority first (bound and activated).
        ctx: The episode's context (handed to `Guard.envelope`).
    """

    def __init__(self, guards: Sequence[Guard], ctx: Context) -> None:
        self.guards = list(guards)
        self.checks = tuple(g.check for g in self.guards)
        """Every guard's full `check`, in priority order."""
        watched: dict[tuple[int, int, int, int], _Watched] = {}
        equal: list[tuple[np.ndarray, np.ndarray]] = []
        scalars: dict[Callable[[], float], float] = {}
        open_checks: list[Callable[[Context], Violation | None]] = []
        self._stateful: list[Guard] = []
        for guard in self.guards:
            env = guard.envelope(ctx)
            if env is None:
                open_checks.append(guard.check)
                continue
            if env.stateful:
                self._stateful.append(guard)
            for view, lo, hi in env.bounds:
                _add_bounds(watched, view, lo, hi)
            for a, b in env.equal:
                if a.ndim != 1 or a.shape != b.shape:
                    raise ValueError(
                        f"{guard.name}: an envelope's equal pair must be two 1-D views of one "
                        f"length, got shapes {a.shape} and {b.shape}"
                    )
            equal += env.equal
            for read, limit in env.scalars:
                scalars[read] = min(limit, scalars.get(read, limit))
        merged = _merged(list(watched.values()))
        # views that must read all zero (contact counts, fault flags): compared as bytes
        zero = [w for w in merged if not any(w.lo) and not any(w.hi)]
        bounded = [w for w in merged if any(w.lo) or any(w.hi)]
        self._zero = tuple((w.view.tobytes, bytes(w.view.nbytes)) for w in zero)
        self._readers = tuple(w.view.tolist for w in bounded)
        self._lo = [v for w in bounded for v in w.lo]
        self._hi = [v for w in bounded for v in w.hi]

        def covered(view: np.ndarray) -> bool:
            if view.ndim != 1 or view.strides[0] != view.itemsize:
                return False
            w = _Watched.of(view, [], [])
            return any(m.covers(w) for m in merged)

        # a pair of which one side is bounded is compared as bytes (one memcmp): the bound
        # keeps a NaN out, and bit for bit equal non-NaN floats are equal floats (a -0.0
        # against a 0.0 only sends the step to the full checks); else as lists of floats
        as_bytes = [covered(a) or covered(b) for a, b in equal]
        self._equal_bytes = tuple(
            (a.tobytes, b.tobytes) for (a, b), raw in zip(equal, as_bytes, strict=True) if raw
        )
        self._equal = tuple(
            (a.tolist, b.tolist) for (a, b), raw in zip(equal, as_bytes, strict=True) if not raw
        )
        self._scalars = tuple(scalars.items())
        self._open = tuple(open_checks)
        """Checks of the guards without an envelope: run in full every step."""
        self._full = any(not g.settled() for g in self._stateful)
        """Check every guard in full this step (a stateful guard's state is not at rest: a
        duration counted before the active set changed)."""
        self.checked = 0
        """Physics steps on which `check` ran (for the step loop's tests)."""
        self.full_checks = 0
        """Steps on which the guards were checked in full (for tests and the bench)."""

    def inside(self) -> bool:
        """Every watched value inside every envelope (NaN never is)."""
        for raw, zeros in self._zero:
            if raw() != zeros:  # bit for bit +0.0 (a NaN, or even a -0.0: the full checks)
                return False
        values: list[float] = []
        for read in self._readers:
            values += read()
        if not (all(map(_le, self._lo, values)) and all(map(_le, values, self._hi))):
            return False
        for a, b in self._equal_bytes:
            if a() != b():
                return False
        for x, y in self._equal:
            if x() != y():
                return False
        for reading, limit in self._scalars:
            if not reading() <= limit:
                return False
        return True

    def check(self, ctx: Context) -> Violation | None:
        """The first violation of the active guards this physics step, or None."""
        self.checked += 1
        if self._full or not self.inside():
            return self._check_full(ctx)
        for always in self._open:  # inside every envelope: the guards without one
            violation = always(ctx)
            if violation is not None:
                return violation
        return None

    def _check_full(self, ctx: Context) -> Violation | None:
        """Every active guard's full `check`, in priority order; the first violation."""
        self.full_checks += 1
        for full in self.checks:
            violation = full(ctx)
            if violation is not None:
                return violation
        self._full = any(not g.settled() for g in self._stateful)
        return None


def _add_bounds(
    watched: dict[tuple[int, int, int, int], _Watched],
    view: np.ndarray,
    lo: Sequence[float],
    hi: Sequence[float],
) -> None:
    lo, hi = [float(v) for v in lo], [float(v) for v in hi]
    if not len(lo) == len(hi) == len(view):
        raise ValueError(f"envelope bounds of {len(lo)}/{len(hi)} values, view of {len(view)}")
    w = _Watched.of(view, lo, hi)
    known = watched.get(w.key)
    if known is None:
        watched[w.key] = w
        return
    # the same memory watched by two guards: inside means inside both bounds
    known.lo = [max(a, b) for a, b in zip(known.lo, lo, strict=True)]
    known.hi = [min(a, b) for a, b in zip(known.hi, hi, strict=True)]
