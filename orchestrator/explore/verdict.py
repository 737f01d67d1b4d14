"""What an explored episode's result line says: refused, passed, or which failures it shows.

A failure is named `invariant:NAME` (engine/invariants.py), `check:NAME` (a success check of
the scenario that did not hold), or `outcome:OUTCOME` (the run did not succeed although every
check held and every invariant did). An episode that the scenario's own validation refused
for its seed (the goals drawn, a `ConfigError`) is `refused`: a clear refusal is what a
variation outside the cell's reach should get, not a failure.
"""

from __future__ import annotations

from typing import Any

from ..batch.episode import forget_prepared, run_task
from ..batch.task import EpisodeTask

__all__ = ["REFUSED", "failures", "message", "primary", "refused", "run_variation"]

REFUSED = "refused"


def run_variation(task: EpisodeTask) -> dict[str, Any]:
    """A worker's run of one variation: `run_task`'s line with the variation's overrides (the
    lines of a shrinking round share a seed), and the worker forgets the prepared scenario."""
    line = run_task(task)
    forget_prepared(task)
    line["overrides"] = list(task.overrides)
    return line


def failures(line: dict[str, Any]) -> list[str]:
    """The failures a result line shows, invariants first (empty: it passed or was refused)."""
    if refused(line):
        return []
    out = []
    for v in (line.get("invariants") or {}).get("violations") or ():
        name = f"invariant:{v.get('invariant')}"
        if name not in out:
            out.append(name)
    out.extend(f"check:{name}" for name, ok in (line.get("success") or {}).items() if not ok)
    outcome = line.get("outcome")
    if outcome != "succeeded" and not any(f.startswith("check:") for f in out):
        error = line.get("error") or {}
        out.append(f"outcome:{outcome}" + (f":{error['type']}" if error.get("type") else ""))
    return out


def refused(line: dict[str, Any]) -> bool:
    """The scenario's validation refused the variation for its seed."""
    error = line.get("error") or {}
    return line.get("outcome") == "error" and error.get("type") == "ConfigError"


def primary(line: dict[str, Any]) -> str | None:
    """The failure a counterexample is filed under: its first invariant violation in time,
    else its first failed check, else its outcome (None: it passed or was refused)."""
    found = failures(line)
    if not found:
        return None
    violations = (line.get("invariants") or {}).get("violations") or ()
    if violations:
        first = min(violations, key=lambda v: v.get("t", float("inf")))
        return f"invariant:{first.get('invariant')}"
    return found[0]


def message(line: dict[str, Any], name: str) -> str:
    """What the run says about failure `name` (the invariant's or check's message)."""
    kind, _, what = name.partition(":")
    if kind == "invariant":
        for v in (line.get("invariants") or {}).get("violations") or ():
            if v.get("invariant") == what:
                return str(v.get("message", ""))
    if kind == "check":
        return str((line.get("success_detail") or {}).get(what, ""))
    reason = line.get("reason") or line.get("error") or {}
    return str(reason.get("message", "")) if isinstance(reason, dict) else str(reason)
