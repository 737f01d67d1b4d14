"""The YAML language: models of machines and scenarios, loading with line numbers, includes,
overrides, static validation, diagnostics, JSON Schemas and graph drawing.

Nothing here simulates: a machine or a scenario can be loaded, checked and drawn without a
physics engine.
"""

from .diagnostics import Diagnostic
from .load import LoadedScenario, load_machine, load_scenario
from .loading import MachineNode

__all__ = ["Diagnostic", "LoadedScenario", "MachineNode", "load_machine", "load_scenario"]
