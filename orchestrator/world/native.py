"""Which path runs the per-physics-step arithmetic: the compiled one or its Python twin.

`orchestrator.world._native` (orchestrator/world/_native.c, built by `pip install` when a C
compiler is present) computes the wrist sensor's noise (`WristForceNoise`), the wrist force
(`Context.wrist_force_norm_sq`, `true_wrist_force_norm_sq`) and the guards' envelope test
(`GuardBank`) in C: the same operations in the same order, no fused multiply-add, so both paths
give the same results bit for bit (tests/test_native.py holds them to it). Without it, or with
the environment variable `ORCHESTRATOR_PURE_PYTHON=1`, the pure-Python path runs.

Objects choose their path when they are built (`native()`), so a test can build one of each.
"""

from __future__ import annotations

import ctypes
import importlib
import os
from types import ModuleType

import mujoco

__all__ = ["PURE_PYTHON_ENV", "compiled", "native", "time_address"]

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


_MARKS = (1234.5678125, -8765.4321875)
"""Two values no field before `time` holds at rest, written to `time` to find it."""
_SCAN_DOUBLES = 256
"""How far past the start of the `timer` array `time` is looked for [doubles]."""


def time_address(data: mujoco.MjData) -> int:
    """The address of `data.time` in memory, 0 if it cannot be found.

    The bindings return `time` as a new Python float on every read (~0.2 us, more with cold
    caches); the compiled code reads the double in place instead. mjData keeps `time` a few
    hundred bytes after its `timer` array (whose address numpy exposes), so the double is
    found by writing two marker values to `time` and looking for both at the same place, the
    search reading forwards from `timer` and stopping at the first hit (it never reads past the
    field it looks for). The original value is restored.
    """
    start = int(data.timer.duration.__array_interface__["data"][0])
    before = data.time
    found: set[int] = set()
    try:
        for mark in _MARKS:
            data.time = mark
            cells = (ctypes.c_double * _SCAN_DOUBLES).from_address(start)
            hit = next((i for i in range(_SCAN_DOUBLES) if cells[i] == mark), None)
            if hit is None:
                return 0
            found.add(hit)
    finally:
        data.time = before
    if len(found) != 1:
        return 0
    address = start + 8 * found.pop()
    return address if ctypes.c_double.from_address(address).value == before else 0
