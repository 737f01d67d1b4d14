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

import os
from types import ModuleType

__all__ = ["PURE_PYTHON_ENV", "compiled", "native"]

PURE_PYTHON_ENV = "ORCHESTRATOR_PURE_PYTHON"
"""Set to 1 to run the pure-Python path although the compiled one is built."""

try:
    from . import _native as _compiled  # type: ignore[attr-defined]
except ImportError:  # not built (no compiler at install time): the Python twin runs
    _compiled = None

compiled: ModuleType | None = _compiled
"""The compiled module, None if it was not built."""


def native() -> ModuleType | None:
    """The compiled module if it is built and not switched off, else None (pure Python)."""
    if compiled is None or os.environ.get(PURE_PYTHON_ENV, "") not in ("", "0"):
        return None
    return compiled
