"""The YAML language: models of machines and scenarios, loading with line numbers, includes,
overrides, static validation, diagnostics, JSON Schemas and graph drawing.

Nothing here simulates: a machine or a scenario can be loaded, checked and drawn without a
physics engine.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from .diagnostics import Diagnostic
    from .load import LoadedScenario, load_machine, load_scenario
    from .loading import MachineNode

__all__ = ["Diagnostic", "LoadedScenario", "MachineNode", "load_machine", "load_scenario"]

_HOMES = {
    "Diagnostic": "diagnostics",
    "LoadedScenario": "load",
    "MachineNode": "loading",
    "load_machine": "machines",
    "load_scenario": "load",
}
"""Where each name of `__all__` lives. Imported when first asked for (PEP 562): importing one
module of this package (`validate_paths`, `diagnostics`) then does not import every other,
and validating a machine loads no scenario model (docs/performance.md, "Start-up")."""


def __getattr__(name: str) -> Any:
    if name not in _HOMES:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(f"{__name__}.{_HOMES[name]}"), name)
    globals()[name] = value
    return value
