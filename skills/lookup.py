"""`lookup`: branch on a value through a table (a class -> its bin)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, ClassVar

from pydantic import Field

from .base import Skill, SkillParams

if TYPE_CHECKING:
    from orchestrator.engine.context import Context

__all__ = ["Lookup"]


class LookupParams(SkillParams):
    table: dict[str, Any] | list[Any] = Field(
        min_length=1,
        description="Key -> value (e.g. `{A: bin_A, B: bin_B}`), or a list read by index.",
    )
    key: str | int | bool = Field(description="What to look up (e.g. `$task.class`).")
    wrap: bool = Field(
        default=False,
        description="A list is read at `key` modulo its length (take turns: `key: $count`).",
    )
    into: str = Field(description="Blackboard key the value is written to.")


class Lookup(Skill):
    """Write `table[key]` to `into`: outcome `found`, or `missing` (nothing written) when the
    table has no such key. A list `table` is read by index (`wrap`: modulo its length, so a
    counter takes turns through it)."""

    name: ClassVar[str] = "lookup"
    Params: ClassVar[type[SkillParams]] = LookupParams
    outcomes: ClassVar[tuple[str, ...]] = ("found", "missing")
    writes: ClassVar[dict[str, str]] = {"into": "any"}

    params: LookupParams

    def step(self, ctx: Context) -> str | None:
        p = self.params
        if isinstance(p.table, list):
            i = p.key if isinstance(p.key, int) and not isinstance(p.key, bool) else None
            if i is not None and p.wrap:
                i %= len(p.table)
            if i is None or not 0 <= i < len(p.table):
                return "missing"
            ctx.blackboard[p.into] = p.table[i]
            return "found"
        if str(p.key) not in p.table:
            return "missing"
        ctx.blackboard[p.into] = p.table[str(p.key)]
        return "found"

    def explain(self, ctx: Context) -> str | None:
        p = self.params
        if isinstance(p.table, list):
            return f"no item {p.key!r} in a list of {len(p.table)}"
        return f"no {str(p.key)!r} in the table (keys: {', '.join(p.table)})"
