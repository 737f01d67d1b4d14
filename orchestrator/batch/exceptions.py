"""Errors of the batch runner."""

from __future__ import annotations

from ..exceptions import OrchestratorError

__all__ = ["BatchError"]


class BatchError(OrchestratorError):
    """The batch cannot start or continue as asked (the message says how to fix it)."""
