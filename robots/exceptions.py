"""Errors raised while building robots."""

from orchestrator.exceptions import OrchestratorError

__all__ = ["RobotError"]


class RobotError(OrchestratorError):
    """A robot model could not be found or assembled."""
