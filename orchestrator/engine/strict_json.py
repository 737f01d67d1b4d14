"""Strict JSON out: every JSON the project prints or writes parses with any JSON parser.

Python's `json.dumps` writes `NaN`, `Infinity` and `-Infinity` for non-finite floats: not JSON
(RFC 8259), and `jq`, JavaScript's `JSON.parse` and most other readers refuse the whole
document. A run's figures can be non-finite (a planner's reply, a sensor that returned NaN, a
metric of a diverged run), so everything printed with `--json`, the batch files and the live
status stream go through `dumps`, which writes a non-finite number as `null` (no number at
all is the honest reading) and refuses anything it cannot write as JSON.
"""

from __future__ import annotations

import json
import math
from typing import Any

__all__ = ["dumps", "strict"]


def strict(value: Any) -> Any:
    """`value` with every non-finite float (NaN, +-inf), at any depth, replaced by None.

    Mappings and sequences are copied only where something changes; tuples become lists (as
    JSON writes them anyway). numpy scalars that are floats (`np.float64`) are Python floats.
    """
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: strict(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [strict(v) for v in value]
    return value


def dumps(value: Any, **kwargs: Any) -> str:
    """`json.dumps` of `strict(value)`, with `allow_nan=False`: strict JSON or an error.

    Args:
        value: What to write.
        **kwargs: Passed to `json.dumps` (`indent`, `default`, ...).
    """
    return json.dumps(strict(value), allow_nan=False, **kwargs)
