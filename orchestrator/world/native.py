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
from typing import TYPE_CHECKING

if TYPE_CHECKING:
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
