"""Batch evaluation: many seeded episodes of a scenario on local processes or Ray.

`run_batch(BatchConfig(...))` validates the scenario once, runs the seeds not yet in
`DIR/results.jsonl` (one line per episode, written as each ends), and writes
`DIR/summary.json`. The heavy parts (physics, Ray) load only when a batch runs.
"""

from __future__ import annotations

from .config import BackendName, BatchConfig, RecordMode
from .exceptions import BatchError
from .run import run_batch
from .summary import BatchSummary

__all__ = ["BackendName", "BatchConfig", "BatchError", "BatchSummary", "RecordMode", "run_batch"]
