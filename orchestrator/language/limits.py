"""Limits on what a machine or scenario file may ask of the loader.

Every input is answered quickly, whatever it holds: a file larger than `max_file_bytes`, nested
deeper than `max_depth`, with more than `max_nodes` values once its aliases are expanded, or
with machines nested deeper than `max_machine_depth` is refused with one located message
instead of exhausting memory, the stack or the user's patience. The defaults are far above
what any real task flow needs (the bundled pick_place scenario and its machines: 4 KiB, depth
7, 400 nodes); widen them with the environment variable `ORCHESTRATOR_LIMITS`, e.g.
`ORCHESTRATOR_LIMITS="max_file_bytes=8388608,max_nodes=2000000"`.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, fields, replace

from ..exceptions import ConfigError
from .diagnostics import Diagnostic

__all__ = ["ENV_VAR", "InputLimits", "current_limits"]

ENV_VAR = "ORCHESTRATOR_LIMITS"
"""Environment variable that widens (or narrows) the limits: `name=value,name=value`."""


@dataclass(frozen=True)
class InputLimits:
    """Caps on one input file and on the machine tree built from it.

    Attributes:
        max_file_bytes: Size of one YAML file [bytes] (default 512 KiB).
        max_depth: Nesting of YAML mappings and lists in one file, aliases expanded.
        max_nodes: Values (scalars, mappings, lists) in one file, each alias counted with
            everything it expands to (stops "billion laughs" before any memory is spent).
        max_machine_depth: Machines nested in machines, inline `states:` and included files
            alike.
        max_states: States in a machine tree once nested and included machines are expanded
            (an included machine counts once per place that includes it).
        max_ref_chars: Length of a `machine:` reference [characters].
    """

    max_file_bytes: int = 1 << 19
    max_depth: int = 64
    max_nodes: int = 250_000
    max_machine_depth: int = 24
    max_states: int = 50_000
    max_ref_chars: int = 1024


def current_limits() -> InputLimits:
    """The defaults, changed by `ORCHESTRATOR_LIMITS` when it is set.

    Raises:
        ConfigError: The variable names an unknown limit or a value that is not a positive
            integer.
    """
    text = os.environ.get(ENV_VAR, "").strip()
    limits = InputLimits()
    if not text:
        return limits
    names = tuple(f.name for f in fields(InputLimits))
    changes: dict[str, int] = {}
    for item in text.split(","):
        name, _, value = item.partition("=")
        name = name.strip()
        if name not in names:
            raise ConfigError(
                [Diagnostic(f"${ENV_VAR}", 0, 0, name[:80] or item[:80], "unknown limit", names)]
            )
        try:
            number = int(value.strip())
        except ValueError:
            number = 0
        if number < 1:
            message = f"expected a positive integer, got {value[:80]!r}"
            raise ConfigError([Diagnostic(f"${ENV_VAR}", 0, 0, name, message)])
        changes[name] = number
    return replace(limits, **changes)
