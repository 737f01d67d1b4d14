"""Statistics of a batch: binomial confidence intervals and percentiles."""

from __future__ import annotations

import math
from collections.abc import Sequence

__all__ = ["Z_95", "percentile", "wilson_interval"]

Z_95 = 1.959963984540054
"""The standard normal quantile of a two-sided 95 % interval."""


def wilson_interval(successes: int, trials: int, z: float = Z_95) -> tuple[float, float]:
    """Wilson score interval of a success probability.

    Unlike the normal approximation it stays inside [0, 1] and is not degenerate at 0 or n
    successes, which matters here: a good flow has success rates close to 1.

    Args:
        successes: Number of successes, 0 <= successes <= trials.
        trials: Number of trials; with 0 trials the interval is [0, 1].
        z: Standard normal quantile of the confidence level (1.96 for 95 %).

    Returns:
        The lower and upper bound, in [0, 1].
    """
    if not 0 <= successes <= trials:
        raise ValueError(f"successes must be in [0, trials], got {successes} of {trials}")
    if trials == 0:
        return 0.0, 1.0
    n = float(trials)
    p = successes / n
    z2 = z * z
    denom = 1.0 + z2 / n
    centre = (p + z2 / (2.0 * n)) / denom
    half = z * math.sqrt(p * (1.0 - p) / n + z2 / (4.0 * n * n)) / denom
    lo = 0.0 if successes == 0 else max(0.0, centre - half)
    hi = 1.0 if successes == trials else min(1.0, centre + half)
    return lo, hi


def percentile(values: Sequence[float], q: float) -> float:
    """The q-th percentile with linear interpolation between ranks (numpy's default).

    Args:
        values: A non-empty sample.
        q: Percentile in [0, 100].
    """
    if not values:
        raise ValueError("percentile of an empty sample")
    if not 0.0 <= q <= 100.0:
        raise ValueError(f"q must be in [0, 100], got {q}")
    xs = sorted(values)
    pos = (len(xs) - 1) * q / 100.0
    lo = math.floor(pos)
    hi = min(lo + 1, len(xs) - 1)
    return xs[lo] + (xs[hi] - xs[lo]) * (pos - lo)
