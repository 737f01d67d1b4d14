"""Which path runs the per-physics-step arithmetic: the compiled one or its Python twin.

`orchestrator.world._native` (orchestrator/world/_native.c, built by `pip install` when a C
compiler is present) computes the wrist sensor's noise (`WristForceNoise`), the wrist force
(`WristSensor.norm_sq`, `true_norm_sq`, world/wrist.py) and the guards' envelope test
(`GuardBank`) in C: the same operations in the same order, no fused multiply-add, so both paths
give the same results bit for bit (tests/test_native.py holds them to it). Without it, or with
the environment variable `ORCHESTRATOR_PURE_PYTHON=1`, the pure-Python path runs.

Objects choose their path when they are built (`native()`), so a test can build one of each.

The simulated time that keys their per-instant readings is the world's `StepClock`
(world/step_clock.py), an attribute both paths read: no C reads MjData's `time`.

Snapshots (engine/snapshot) pickle the compiled objects too: an `FtNoise` pickles itself (its
stream's position included); a `WristForce` reads MjData's views through their addresses, so
`REDUCERS` rebuilds it on the restored views; an `Envelope` holds raw addresses and is rebuilt
by its owner (guards/bank.py).
"""

from __future__ import annotations

import importlib
import os
from collections.abc import Callable
from types import ModuleType
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from .step_clock import StepClock

__all__ = ["PURE_PYTHON_ENV", "REDUCERS", "compiled", "native"]

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


def _rebuild_wrist_force(
    clock: StepClock,
    views: tuple[Any, Any],
    bias: tuple[float, float, float],
    weight: tuple[float, float, float],
    noise: Any,
    fallback: Callable[[], float] | None,
) -> Any:
    """A `WristForce` on a snapshot's restored views of MjData: its readings are cached per
    simulated instant only, so the rebuilt one reads what the original would have."""
    assert compiled is not None
    f_site, rot = views
    wf = compiled.WristForce(clock, f_site, rot, bias, weight, noise)
    if fallback is not None:
        wf.set_fallback(fallback)
    return wf


REDUCERS: dict[type, Callable[[Any], tuple]] = (
    {
        compiled.WristForce: lambda w: (
            _rebuild_wrist_force,
            (w.clock, w.views, w.bias, w.weight, w.noise, w.fallback),
        ),
    }
    if compiled is not None
    else {}
)
"""How a snapshot pickles the compiled reader of MjData's views (a `pickle` dispatch table's
entries): it holds their raw addresses, so it is rebuilt on the restored views."""
