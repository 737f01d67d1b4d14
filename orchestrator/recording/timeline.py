"""Per-episode sample buffers and the two timelines every temporal column is sent on."""

from __future__ import annotations

import numpy as np
import rerun as rr

from .paths import SIM_TIME, TICK

__all__ = ["Rows", "seconds_to_ns", "time_columns"]


def seconds_to_ns(t_s: np.ndarray | list[float]) -> np.ndarray:
    """Simulated times [s] as integer nanoseconds (rounded, so 0.29 s is 290 000 000 ns)."""
    return np.rint(np.asarray(t_s, dtype=np.float64) * 1e9).astype(np.int64)


def time_columns(ticks: np.ndarray, t_s: np.ndarray) -> list[rr.TimeColumn]:
    """The `sim_time` (duration) and `tick` (sequence) index columns of a batch of rows.

    Args:
        ticks: Control tick of each row. Shape (n,).
        t_s: Simulated time of each row in [s]. Shape (n,).
    """
    return [
        rr.TimeColumn(SIM_TIME, duration=seconds_to_ns(t_s).astype("timedelta64[ns]")),
        rr.TimeColumn(TICK, sequence=np.asarray(ticks, dtype=np.int64)),
    ]


class Rows:
    """A growable table of samples stamped with control tick and simulated time.

    Each field is a preallocated float64 array of shape (capacity, *shape), exposed as an
    attribute; `append` stamps a row and returns its index, the caller fills the fields in
    place (`rows.pos[i] = data.xpos`). Arrays double when full, so the per-tick cost is a few
    contiguous copies and no allocation.

    Args:
        fields: Field name -> shape of one row's value, e.g. `{"pos": (n_bodies, 3)}`.
        capacity: Rows preallocated before the first growth.
    """

    def __init__(self, fields: dict[str, tuple[int, ...]], capacity: int = 512) -> None:
        self.fields = dict(fields)
        self.ticks = np.zeros(capacity, dtype=np.int64)
        self.t_s = np.zeros(capacity, dtype=np.float64)
        for name, shape in self.fields.items():
            setattr(self, name, np.zeros((capacity, *shape), dtype=np.float64))
        self.n = 0

    def __len__(self) -> int:
        return self.n

    def __getattr__(self, name: str) -> np.ndarray:  # typing aid: fields are set in __init__
        raise AttributeError(f"Rows has no field {name!r} (fields: {', '.join(self.fields)})")

    def append(self, tick: int, t_s: float) -> int:
        """Stamp a new row at control tick `tick`, time `t_s` [s]; return its index."""
        i = self.n
        if i == len(self.ticks):
            self._grow()
        self.ticks[i] = tick
        self.t_s[i] = t_s
        self.n = i + 1
        return i

    def take(self) -> tuple[np.ndarray, np.ndarray, dict[str, np.ndarray]]:
        """The rows so far as `(ticks, t_s, {field: values})` copies; the buffer is emptied."""
        n = self.n
        values = {name: getattr(self, name)[:n].copy() for name in self.fields}
        out = self.ticks[:n].copy(), self.t_s[:n].copy(), values
        self.n = 0
        return out

    def _grow(self) -> None:
        for name in ("ticks", "t_s", *self.fields):
            old = getattr(self, name)
            new = np.zeros((2 * len(old), *old.shape[1:]), dtype=old.dtype)
            new[: len(old)] = old
            setattr(self, name, new)
