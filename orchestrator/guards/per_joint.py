"""One definition of a symmetric per-joint limit |x_i| <= limit_i, for the guards that watch a
per-arm-joint reading of MuJoCo's (`joint_velocity`: qvel, `joint_acceleration`: qacc).

The limits are resolved once (`resolve_limits`: the scenario's or the robot's datasheet
figures, times `scale`), and the same lists serve the guard's `check` (`first_beyond`) and its
envelope (`envelope_bounds`): the condition is stated here and nowhere else.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

__all__ = [
    "arm_view",
    "envelope_bounds",
    "first_beyond",
    "limit_problems",
    "resolve_limits",
]


def resolve_limits(
    given: Sequence[float] | None,
    datasheet: Sequence[float],
    scale: float,
    key: str,
    unit: str,
    at_most_datasheet: bool = False,
) -> list[float]:
    """The limit per arm joint: `given` (else the robot's `datasheet`), times `scale`.

    Raises:
        ValueError: `given` has not one value per arm joint, or (`at_most_datasheet`) a value
            above the datasheet's for its joint.
    """
    n = len(datasheet)
    limits = list(datasheet) if given is None else list(given)
    if len(limits) != n:
        raise ValueError(f"{key} needs {n} values (one per arm joint), got {len(limits)}")
    if at_most_datasheet:
        for i, (v, d) in enumerate(zip(limits, datasheet, strict=True)):
            if v * scale > d:
                raise ValueError(
                    f"{key}: joint {i + 1}'s limit {v * scale:g} {unit} is above the robot's "
                    f"datasheet limit {d:g} {unit}: a limit may be tighter, never looser"
                )
    return [v * scale for v in limits]


def limit_problems(
    given: Sequence[float] | None,
    datasheet: Sequence[float],
    scale: float,
    key: str,
    unit: str,
    at_most_datasheet: bool = False,
) -> list[tuple[str, str]]:
    """`resolve_limits`'s refusal as (key, message) pairs, for `Guard.robot_problems`."""
    try:
        resolve_limits(given, datasheet, scale, key, unit, at_most_datasheet)
    except ValueError as exc:
        return [(key, str(exc))]
    return []


def first_beyond(values: Sequence[float], limits: Sequence[float]) -> int | None:
    """The index of the first value with |value| > its limit, or None. NaN is never beyond
    (compares false): divergence is the runner's to report, not a violation."""
    for i, (v, lim) in enumerate(zip(values, limits, strict=True)):
        if v > lim or v < -lim:
            return i
    return None


def envelope_bounds(limits: Sequence[float]) -> tuple[list[float], list[float]]:
    """(lo, hi) of the envelope where `first_beyond` is certainly None: -limit <= x <= limit
    (NaN is outside it: the full check then decides)."""
    return [-v for v in limits], list(limits)


def arm_view(array: np.ndarray, dofs: Sequence[int]) -> np.ndarray | None:
    """`array[dofs]` as a view (bound once, read every step) when the arm's dofs are
    contiguous, else None (read `array[dofs]`, a copy, at every check)."""
    view = array[dofs[0] : dofs[-1] + 1]
    return view if len(view) == len(dofs) else None
