"""What a live command or a planner's reply may set: a machine's inputs, with finite values.

Safety parameters are not commands. `orchestrator run --set` may change any scenario value
(the local user owns the scenario), but what arrives over the live channel or from a planner
may set only the blackboard keys the task's machine declares as its inputs
(language/inputs.py): never a scenario path (`guards.*`, `physics.*`, `scene.*`, `robot.*`,
...) nor another machine (`machine=`). Limits change only by starting a session with another
scenario. A value that is not finite (NaN, infinity, or a text that reads as one) is refused
as such before anything else is looked at.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from ..language.diagnostics import Diagnostic
from ..language.inputs import machine_inputs
from ..language.loading import MachineNode
from ..language.overrides import Override, parse_override
from ..language.scenario import Scenario
from .guardrail import is_finite

__all__ = ["parse_sets", "refuse_non_inputs"]

_LIMITS_RULE = (
    "a live command or a planner may set only the machine's inputs; limits and scenario "
    "values change only by starting a session with another scenario"
)


def parse_sets(sets: Sequence[str]) -> tuple[list[Override], str | None]:
    """Read a command's `KEY=VALUE` texts, refusing what no machine input can be.

    Returns:
        The overrides, and why they are refused (None: they may go on to loading, which checks
        that each key is a blackboard key of the machine and its value of the declared type).
    """
    out = []
    for text in sets:
        ov = parse_override(text)
        if isinstance(ov, Diagnostic):
            return [], f"{ov.path}: {ov.message}"
        key = ".".join(ov.path)
        if len(ov.path) != 1 or ov.path[0] in Scenario.model_fields or ov.path[0] == "parcels":
            return [], f"`{key}` is a scenario value, not an input: {_LIMITS_RULE}"
        out_of_range = _out_of_range(ov.value)
        if out_of_range is not None:
            return [], f"{key}: {out_of_range} is out of range (at most {MAX_ABS:g} in size)"
        if not is_finite(ov.value):
            return [], f"{key} = {ov.value!r}: not finite"
        if ov.value is None:
            return [], (
                f"{key}=null: give a value of the type the machine declares for it (a pose or "
                "position [x, y, z], a name...); a live task's input cannot be left unset"
            )
        out.append(ov)
    return out, None


MAX_ABS = 1e15
"""Largest magnitude of a number in a `--set` value (a metre, a second or a count never
comes near it; an integer beyond it cannot even become a float)."""


def _out_of_range(value: Any) -> str | None:
    """The first number in `value` (nested lists and mappings) too large, as a short text."""
    if isinstance(value, bool):
        return None
    if isinstance(value, int | float):
        if isinstance(value, int) and abs(value) > MAX_ABS:
            digits = len(str(abs(value))) if value.bit_length() < 14_000 else "thousands of"
            return f"an integer of {digits} digits"
        return None
    items = value.values() if isinstance(value, dict) else value if isinstance(value, list) else ()
    for item in items:
        found = _out_of_range(item)
        if found is not None:
            return found
    return None


def refuse_non_inputs(machine: MachineNode, keys: Sequence[str]) -> str | None:
    """Why setting `keys` on `machine` is refused (a key it does not declare as an input)."""
    inputs = machine_inputs(machine)
    for key in keys:
        if key not in inputs:
            valid = ", ".join(inputs) or "none: it takes no values"
            return (
                f"`{key}` is not an input of machine {machine.name!r}: a key is one when the "
                "machine declares it `input: true`, or by default when a motion target or a "
                f"position hint reads it (valid: {valid})"
            )
    return None
