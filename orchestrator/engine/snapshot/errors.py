"""The one error of snapshots (its own module: every other snapshot module raises it)."""

from __future__ import annotations

from ...exceptions import OrchestratorError

__all__ = ["SnapshotError"]


class SnapshotError(OrchestratorError):
    """A snapshot cannot be written or read (the message says what and where)."""
