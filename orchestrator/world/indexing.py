"""Index arrays made cheap for the hot path: contiguous indices become a slice (numpy only, so
that a guard's or a skill's declaration can import it without loading MuJoCo)."""

from __future__ import annotations

import numpy as np

__all__ = ["as_index"]


def as_index(idx: np.ndarray) -> slice | np.ndarray:
    """A slice when the indices are contiguous (cheaper on the hot path)."""
    if len(idx) and np.all(np.diff(idx) == 1):
        return slice(int(idx[0]), int(idx[-1]) + 1)
    return idx
