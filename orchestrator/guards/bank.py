"""Every active guard checked every physics step, at the cost of one test of their envelopes.

A guard's `check` is exact but it is Python: eight guards checked one after another cost about
as much as everything else the framework adds to a physics step. Almost always every value is
far inside its limit. So each guard may declare an *envelope* (`Guard.envelope`): bounds on the
raw readings it watches (views into MjData, the controller's output, its own state) inside
which its `check` certainly returns None and changes nothing. `GuardBank` gathers the envelopes
of all active guards once, when the active set changes, and every physics step

1. compares the views that must read zero (contact counts, fault flags) with zero bytes
   (`tobytes()`, one memcmp each; a NaN or a -0.0 is not zero there),
2. reads each bounded view once (one `tolist()` per distinct view) and tests all bounds with
   two C-level passes (`all(map(le, ...))`), the pairs that must read equal with one list
   comparison, and the scalars (the wrist force) with one comparison each,
3. only if a value left the envelope (or a NaN appeared, which no bound admits), runs every
   active guard's full `check` in priority order, exactly as if there were no envelope.

Guards without an envelope are checked in full every step. Nothing changes what fires or when:
inside the envelope no guard could have fired; outside it the guards run as they always did,
so the violation, its message and the step it fires on are the same (tests/test_guard_bank.py).
"""

from __future__ import annotations

import operator
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..world.native import native
from .base import Guard, Violation

if TYPE_CHECKING:
    from ..engine.context import Context

__all__ = ["Addresses", "GuardBank"]

_le = operator.le


class Addresses(dict[int, tuple[np.ndarray, int]]):
    """Memory addresses of views, by `id()` (the view is kept with its address, so the id cannot
    be reused while it is cached): an executor keeps one for its episode and hands it to every
    bank it builds (reading `__array_interface__` costs ~10 us, and a bank is built at every
    state change). Ids and addresses do not survive a process: a snapshot (engine/snapshot)
    pickles it empty."""

    def __reduce__(self) -> tuple:
        return (type(self), ())


def _address(view: np.ndarray, cache: Addresses) -> int:
    hit = cache.get(id(view))
    if hit is not None and hit[0] is view:
        return hit[1]
    address = int(view.__array_interface__["data"][0])
    cache[id(view)] = (view, address)
    return address


@dataclass
class _Watched:
    """One watched view, the bounds on each of its elements, and where it starts in memory."""

    view: np.ndarray
    lo: list[float]
    hi: list[float]
    address: int

    def __getstate__(self) -> dict:
        return {**vars(self), "address": 0}  # an address does not survive a process

    def __setstate__(self, state: dict) -> None:
        vars(self).update(state)
        self.address = int(self.view.__array_interface__["data"][0])


def _merged(watched: list[_Watched], cache: Addresses) -> list[_Watched]:
    """Views of one array that follow each other in memory, as one view (one `tolist()` a
    step instead of several): e.g. the arm's joints and the fingers' in `qpos`."""
    out: list[_Watched] = []
    for w in sorted(watched, key=lambda w: w.address):
        last = out[-1] if out else None
        base = w.view.base
        if (
            last is not None
            and isinstance(base, np.ndarray)
            and last.view.base is base
            and base.ndim == 1
            and base.flags.c_contiguous
            and w.view.strides[0] == last.view.strides[0] == base.itemsize
            and last.address + last.view.nbytes == w.address
        ):
            start = (last.address - _address(base, cache)) // base.itemsize
            view = base[start : start + len(last.view) + len(w.view)]
            out[-1] = _Watched(view, last.lo + w.lo, last.hi + w.hi, last.address)
        else:
            out.append(w)
    return out


def _key(view: np.ndarray, cache: Addresses) -> tuple[int, int, int]:
    if view.ndim != 1:
        raise ValueError(f"an envelope view must be 1-D, got shape {view.shape}")
    return (_address(view, cache), len(view), view.strides[0])


class GuardBank:
    """The active guards, in priority order, checked as one (see the module docstring).

    Args:
        guards: The active guards, highest priority first (bound and activated).
        ctx: The episode's context (handed to `Guard.envelope`).
        addresses: Where the watched views start in memory, cached across the banks of an
            episode (None: this bank's own).
    """

    def __init__(
        self, guards: Sequence[Guard], ctx: Context, addresses: Addresses | None = None
    ) -> None:
        cache: Addresses = Addresses() if addresses is None else addresses
        self.guards = list(guards)
        self.checks = tuple(g.check for g in self.guards)
        """Every guard's full `check`, in priority order."""
        watched: dict[tuple[int, int, int], _Watched] = {}
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
                self._add_bounds(watched, view, lo, hi, cache)
            for a, b in env.equal:
                if a.ndim != 1 or a.shape != b.shape:
                    raise ValueError(
                        f"{guard.name}: an envelope's equal pair must be two 1-D views of one "
                        f"length, got shapes {a.shape} and {b.shape}"
                    )
            equal += env.equal
            for read, limit in env.scalars:
                scalars[read] = min(limit, scalars.get(read, limit))
        merged = _merged(list(watched.values()), cache)

        def covered(view: np.ndarray) -> bool:
            return _covered(view, merged, cache)

        # views that must read all zero (contact counts, fault flags): one `any()` for them
        zero = [w for w in merged if not any(w.lo) and not any(w.hi)]
        bounded = [w for w in merged if any(w.lo) or any(w.hi)]
        self._zero = tuple((w.view.tobytes, bytes(w.view.nbytes)) for w in zero)
        self._readers = tuple(w.view.tolist for w in bounded)
        self._lo = [v for w in bounded for v in w.lo]
        self._hi = [v for w in bounded for v in w.hi]
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
        self._envelope = (zero, bounded, equal, as_bytes)
        """What `compiled` tests (a snapshot's restored bank compiles it again)."""
        self.compiled: Callable[[], bool] | None = None
        """`inside()` in C (world/native.py), None on the pure-Python path."""
        self._compile(cache)
        self._open = tuple(open_checks)
        """Checks of the guards without an envelope: run in full every step."""
        self._full = any(not g.settled() for g in self._stateful)
        """Check every guard in full this step (a stateful guard's state is not at rest: a
        duration counted before the active set changed)."""
        self.full_checks = 0
        """Steps on which the guards were checked in full (for tests and the bench)."""

    def _compile(self, cache: Addresses) -> None:
        self.compiled = _compiled(*self._envelope, self._scalars, cache)
        if self.compiled is not None:
            self.check = self._check_compiled  # type: ignore[method-assign]
            self.inside = self.compiled  # type: ignore[method-assign]

    def __getstate__(self) -> dict:
        # the compiled test reads raw addresses: a snapshot (engine/snapshot) compiles it
        # again on the restored views
        return {k: v for k, v in vars(self).items() if k not in ("compiled", "check", "inside")}

    def __setstate__(self, state: dict) -> None:
        vars(self).update(state)
        self.compiled = None
        self._compile(Addresses())

    @staticmethod
    def _add_bounds(
        watched: dict[tuple[int, int, int], _Watched],
        view: np.ndarray,
        lo: Sequence[float],
        hi: Sequence[float],
        cache: Addresses,
    ) -> None:
        lo, hi = [float(v) for v in lo], [float(v) for v in hi]
        if not len(lo) == len(hi) == len(view):
            raise ValueError(f"envelope bounds of {len(lo)}/{len(hi)} values, view of {len(view)}")
        key = _key(view, cache)
        known = watched.get(key)
        if known is None:
            watched[key] = _Watched(view, lo, hi, key[0])
            return
        # the same view watched by two guards: inside means inside both bounds
        known.lo = [max(a, b) for a, b in zip(known.lo, lo, strict=True)]
        known.hi = [min(a, b) for a, b in zip(known.hi, hi, strict=True)]

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
        if not self._full:
            # `inside()` written out: this runs every physics step, where a call counts
            for raw, zeros in self._zero:
                if raw() != zeros:
                    return self._check_full(ctx)
            values: list[float] = []
            for read in self._readers:
                values += read()
            if not (all(map(_le, self._lo, values)) and all(map(_le, values, self._hi))):
                return self._check_full(ctx)
            for a, b in self._equal_bytes:
                if a() != b():
                    return self._check_full(ctx)
            for x, y in self._equal:
                if x() != y():
                    return self._check_full(ctx)
            for reading, limit in self._scalars:
                if not reading() <= limit:
                    return self._check_full(ctx)
            return self._check_open(ctx) if self._open else None
        return self._check_full(ctx)

    def _check_compiled(self, ctx: Context) -> Violation | None:
        """`check` with the envelope tested in C (`self.compiled`)."""
        if self._full or not self.compiled():  # type: ignore[misc]
            return self._check_full(ctx)
        return self._check_open(ctx) if self._open else None

    def _check_open(self, ctx: Context) -> Violation | None:
        """Inside every envelope: the full checks of the guards without one."""
        for always in self._open:
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


def _covered(view: np.ndarray, watched: Sequence[_Watched], cache: Addresses) -> bool:
    """Every element of the 1-D `view` lies in one of the `watched` views (so it is bounded)."""
    if view.ndim != 1 or view.strides[0] != view.itemsize:
        return False
    start = _address(view, cache)
    for w in watched:
        if w.view.strides[0] != w.view.itemsize:
            continue
        if w.address <= start and start + view.nbytes <= w.address + w.view.nbytes:
            return True
    return False


def _compiled(
    zero: list[_Watched],
    bounded: list[_Watched],
    equal: list[tuple[np.ndarray, np.ndarray]],
    as_bytes: list[bool],
    scalars: tuple[tuple[Callable[[], float], float], ...],
    cache: Addresses,
) -> Callable[[], bool] | None:
    """The envelope test in C, tested in the order of `GuardBank.inside` (so the scalars'
    readings, which draw the wrist sensor's noise, are taken on the same steps); None when the
    compiled module is not in use or a view is not float64 (then Python tests it)."""
    ext = native()
    f8 = np.dtype(np.float64)
    if ext is None or any(w.view.dtype != f8 for w in bounded):
        return None
    if any(a.dtype != f8 or b.dtype != f8 or a.shape != b.shape for a, b in equal):
        return None
    if any(w.view.itemsize > 64 for w in zero):
        return None

    def span(w: _Watched) -> tuple[int, int, int, int]:
        return (w.address, len(w.view), w.view.strides[0], w.view.itemsize)

    pairs = [
        (_address(a, cache), a.strides[0], _address(b, cache), b.strides[0], len(a), raw)
        for (a, b), raw in zip(equal, as_bytes, strict=True)
    ]
    # a reading of the C wrist force is taken in C; any other scalar is called
    reads = [
        (getattr(read, "__self__", None) if _is_compiled_force(read, ext) else read, limit)
        for read, limit in scalars
    ]
    keep = (zero, bounded, equal, scalars)  # the views stay alive as long as the test
    envelope = ext.Envelope(
        [span(w) for w in zero],
        [span(w) for w in bounded],
        [v for w in bounded for v in w.lo],
        [v for w in bounded for v in w.hi],
        pairs,
        reads,
        keep,
    )
    inside: Callable[[], bool] = envelope.inside
    return inside


def _is_compiled_force(read: Callable[[], float], ext: object) -> bool:
    owner = getattr(read, "__self__", None)
    return isinstance(owner, ext.WristForce) and read == owner.norm_sq  # type: ignore[attr-defined]
