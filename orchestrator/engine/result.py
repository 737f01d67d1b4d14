"""RunResult: the JSON a run prints (a contract: the README's `run --json` example and
docs/invariants.md)."""

from __future__ import annotations

import math
from typing import Any, Literal

from pydantic import BaseModel, Field

__all__ = ["Outcome", "RunResult"]

Outcome = Literal["succeeded", "failed", "aborted", "error"]

EXIT_CODES: dict[str, int] = {"succeeded": 0, "failed": 1, "aborted": 3, "error": 4}
"""`run`'s exit code per outcome (2 is invalid input; `error`: a skill raised)."""


class RunResult(BaseModel):
    """What happened in one episode."""

    scenario: str
    seed: int
    outcome: Outcome
    final_state: str | None
    reason: dict[str, Any] | None = Field(
        default=None,
        description="Why the run was cut short: the guard violation that aborted it (`guard`, "
        "`message`, `value`, `limit`), or the time limit it reached (`kind: time_limit`, "
        "`message`, `value` and `limit` in s of simulated time; outcome `failed`), or the "
        "wall-clock limit (`kind: max_wall_s`; outcome `error`), or `kind` `final_state` (the "
        "state whose outcome led to a failed final state), `success_check`, `skill_error`, "
        "`diverged`; every one has `state` and `message`. Null only for `succeeded`.",
    )
    sim_time: float = Field(description="Simulated time [s].")
    wall_time: float = Field(description="Wall time of the episode [s] (build + simulate).")
    transitions: list[dict[str, Any]]
    metrics: dict[str, Any]
    success: dict[str, bool]
    retries: dict[str, int] = Field(default_factory=dict)
    success_detail: dict[str, str] = Field(
        default_factory=dict,
        description="Per success check, what it measured against its limit (why it failed).",
    )
    error: dict[str, Any] | None = Field(
        default=None,
        description="Outcome `error`: the skill that raised (`skill`, `method`, `state`, `t`, "
        "`type`, `message`, `where` as file:line, `traceback`); absent otherwise.",
    )
    tasks: list[dict[str, Any]] | None = Field(
        default=None,
        description="The task log of a run with parcels: one entry per parcel (engine/tasks.py)"
        "; absent otherwise.",
    )

    invariants: dict[str, Any] | None = Field(
        default=None,
        description="What held at every physics step and at the end (engine/invariants.py): "
        "`ok`, `violations` (each: `invariant`, `message`, `value`, `limit`, `t`, `state`) and "
        "`worst` (the largest ratio to each datasheet limit); absent where nothing measured it.",
    )

    @property
    def strict_violation(self) -> dict[str, Any] | None:
        """The first invariant violation in time (`run --strict` exits 1 on it), or None."""
        found = (self.invariants or {}).get("violations") or []
        return min(found, key=lambda v: v.get("t", math.inf)) if found else None

    @property
    def exit_code(self) -> int:
        return EXIT_CODES[self.outcome]

    def to_json_dict(self) -> dict[str, Any]:
        out = self.model_dump(mode="json")
        if out["tasks"] is None:
            del out["tasks"]  # runs without parcels print what they always printed
        if out["error"] is None:
            del out["error"]  # only a run whose skill raised has one
        if out["invariants"] is None:
            del out["invariants"]
        return out
