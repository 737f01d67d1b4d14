"""Which path runs the per-physics-step arithmetic: the compiled one or its Python twin.

`orchestrator.world._native` (orchestrator/world/_native.c, built by `pip install` when a C
compiler is present) computes the wrist sensor's noise (`WristForceNoise`), the wrist force
(`Context.wrist_force_norm_sq`, `true_wrist_force_norm_sq`) and the guards' envelope test
(`GuardBank`) in C: the same operations in the same order, no fused multiply-add, so both paths
give the same results bit for bit (tests/test_native.py holds them to it). Without it, or with
the environment variable `ORCHESTRATOR_PURE_PYTHON=1`, the pure-Python path runs.

Objects choose their path when they are built (`native()`), so a test can build one of each.

Snapshots (engine/snapshot) pickle the compiled objects too: an `FtNoise` pickles itself (its
stream's position included); a `Clock` and a `WristForce` read MjData in place, so `REDUCERS`
rebuilds them on the restored MjData (`time_address` found again); an `Envelope` holds raw
addresses and is rebuilt by its owner (guards/bank.py).
"""

from __future__ import annotations

import ctypes
import importlib
import os
from collections.abc import Callable
from types import ModuleType
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    import mujoco

__all__ = ["PURE_PYTHON_ENV", "REDUCERS", "compiled", "native", "time_address"]

PURE_PYTHON_ENV = "ORCHESTRATOR_PURE_PYTHON"
"""Set to 1 to run the pure-Python path although the compiled one is built."""


def _load() -> ModuleType | None:
    try:
        return importlib.import_module(f"{__package__}._native")
    except ImportError:  # not built (no compiler at install time): the Python twin runs
        return None


compiled: ModuleType | None = _load()
"""The compiled module, None if it was not built."""


def native() -> ModuleType | None:
    """The compiled module if it is built and not switched off, else None (pure Python)."""
    if compiled is None or os.environ.get(PURE_PYTHON_ENV, "") not in ("", "0"):
        return None
    return compiled


_MARK = 1234.5678125
"""A value written to `time` once, to check that the address found is `time`'s."""


def time_address(data: mujoco.MjData) -> int:
    """The address of `data.time` in memory, 0 if it cannot be confirmed.

    The bindings return `time` as a new Python float on every read (~0.2 us, more with cold
    caches); the compiled code reads the double in place instead. mjData declares
    `mjtNum time; mjtNum energy[2];` back to back (every `mjdata.h` from MuJoCo 2 to 4), and
    numpy exposes the address of `energy`: `time` is the double just before it, inside the
    struct. That is checked by writing a marker value to `time` through the bindings and
    reading it there; the original value is restored. Any other layout gives 0, and the
    bindings are used.
    """
    address = int(data.energy.__array_interface__["data"][0]) - 8
    cell = ctypes.c_double.from_address(address)
    before = data.time
    try:
        data.time = _MARK
        found = cell.value == _MARK
    finally:
        data.time = before
    return address if found and cell.value == before else 0


def _rebuild_clock(data: mujoco.MjData) -> Any:
    """A `Clock` reading `data`'s time in place (a snapshot's restored MjData)."""
    assert compiled is not None
    return compiled.Clock(data, _address_of_time(data))


def _rebuild_wrist_force(
    data: mujoco.MjData,
    views: tuple[Any, Any],
    bias: tuple[float, float, float],
    weight: tuple[float, float, float],
    noise: Any,
    fallback: Callable[[], float] | None,
) -> Any:
    """A `WristForce` on `data` (a snapshot's restored MjData): its readings are cached per
    simulated instant only, so the rebuilt one reads what the original would have."""
    assert compiled is not None
    f_site, rot = views
    wf = compiled.WristForce(data, f_site, rot, bias, weight, noise, _address_of_time(data))
    if fallback is not None:
        wf.set_fallback(fallback)
    return wf


def _address_of_time(data: mujoco.MjData) -> int:
    address = time_address(data)
    if not address:  # it was found where the snapshot was taken: same MuJoCo, same layout
        raise RuntimeError("cannot find MjData's time in memory to rebuild a compiled reader")
    return address


REDUCERS: dict[type, Callable[[Any], tuple]] = (
    {
        compiled.Clock: lambda c: (_rebuild_clock, (c.data,)),
        compiled.WristForce: lambda w: (
            _rebuild_wrist_force,
            (w.data, w.views, w.bias, w.weight, w.noise, w.fallback),
        ),
    }
    if compiled is not None
    else {}
)
"""How a snapshot pickles the compiled readers of MjData (a `pickle` dispatch table's entries)."""
