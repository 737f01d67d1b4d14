"""Which path runs the per-physics-step arithmetic: the compiled one or its Python twin.

`orchestrator.world._native` (orchestrator/world/_native.c, built by `pip install` when a C
compiler is present) computes the wrist sensor's noise (`WristForceNoise`) and the wrist force
(`WristSensor.norm_sq`, `true_norm_sq`, world/wrist.py) in C: the same operations in the same
order, no fused multiply-add, so both paths give the same results bit for bit
(tests/test_native.py holds them to it). Without it, or with the environment variable
`ORCHESTRATOR_PURE_PYTHON=1`, the pure-Python path runs.

Objects choose their path when they are built (`native()`), so a test can build one of each.

The simulated time that keys their per-instant readings is the world's `StepClock`
(world/step_clock.py), an attribute both paths read: no C reads MjData's `time`.

The guards' envelope test (guards/bank.py) has no compiled twin: measured on whole episodes it
made no difference a run could see (bench/guards_envelope.py).
"""

from __future__ import annotations

import importlib
import os
from types import ModuleType

__all__ = ["PURE_PYTHON_ENV", "compiled", "native"]

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
