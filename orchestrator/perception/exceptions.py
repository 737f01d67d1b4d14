"""Errors of the perception layer."""

from __future__ import annotations

from ..exceptions import OrchestratorError

__all__ = ["PerceptionError"]


class PerceptionError(OrchestratorError):
    """A camera cannot be rendered or a detection request is invalid."""
