"""One error root for the framework, a subclass per area."""

from __future__ import annotations

__all__ = [
    "ConfigError",
    "OrchestratorError",
    "SkillError",
]


class OrchestratorError(Exception):
    """Root of every error this framework raises on purpose."""


class ConfigError(OrchestratorError):
    """User input (a machine, a scenario, an override) is invalid.

    Attributes:
        diagnostics: Every problem found, each naming file, line, key and fix.
    """

    def __init__(self, diagnostics: list, during_run: bool = False) -> None:
        self.diagnostics = list(diagnostics)  # list[Diagnostic]
        self.during_run = during_run
        """True when the problem only showed while simulating (e.g. a bad value read from the
        blackboard): the run was stopped there."""
        super().__init__("\n".join(str(d) for d in self.diagnostics))


class SkillError(OrchestratorError):
    """A skill was used in a way it does not support at run time."""
