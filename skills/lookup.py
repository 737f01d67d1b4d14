"""`lookup`: branch on a value through a table (a class -> its bin)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, ClassVar

from pydantic import Field

from .base import Skill, SkillParams

if TYPE_CHECKING:
    from orchestrator.engine.context import Context

__all__ = ["Lookup"]


class LookupParams(SkillParams):
    table: dict[str, Any] = Field(
        min_length=1, description="Key -> value (e.g. `{A: bin_A, B: bin_B}`)."
    )
    key: str | int | bool = Field(description="What to look up (e.g. `$task.class`).")
    into: str = Field(description="Blackboard key the value is written to.")


class Lookup(Skill):
    """Write `table[key]` to `into`: outcome `found`, or `missing` (nothing written) when the
    table has no such key."""

    name: ClassVar[str] = "lookup"
    Params: ClassVar[type[SkillParams]] = LookupParams
    outcomes: ClassVar[tuple[str, ...]] = ("found", "missing")
    writes: ClassVar[dict[str, str]] = {"into": "any"}

    params: LookupParams

    def step(self, ctx: Context) -> str | None:
        p = self.params
        key = str(p.key)
        if key not in p.table:
            return "missing"
        ctx.blackboard[p.into] = p.table[key]
        return "found"

    def explain(self, ctx: Context) -> str | None:
        return f"no {str(self.params.key)!r} in the table (keys: {', '.join(self.params.table)})"
