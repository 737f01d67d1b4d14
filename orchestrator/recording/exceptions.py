"""Errors of the recording package."""

from __future__ import annotations

from ..exceptions import OrchestratorError

__all__ = ["RecordingError"]


class RecordingError(OrchestratorError):
    """A recorder was configured or used in a way it does not support."""
