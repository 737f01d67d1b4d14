"""`count`: bound a loop of a flow by counting its passes on the blackboard."""

from __future__ import annotations

from typing import TYPE_CHECKING, ClassVar

from pydantic import Field, PositiveInt

from orchestrator.exceptions import SkillError

from .base import Skill, SkillParams

if TYPE_CHECKING:
    from orchestrator.engine.context import Context

__all__ = ["Count"]


class CountParams(SkillParams):
    key: str = Field(description="Blackboard key of the counter (unset counts as 0).")
    max: PositiveInt = Field(le=1_000_000, description="Passes allowed.")


class Count(Skill):
    """Add one to the counter under `key`: `again` while it is at most `max`, `exhausted`
    once it passes it (the counter is left at `max` + 1). A recovery loop that runs through
    a `count` state ends after `max` passes, whatever happens in it:

    ```yaml
    RECOVER:
      skill: count
      with: {key: grasp_attempts, max: 3}
      transitions: {again: APPROACHING, exhausted: GAVE_UP}
    ```

    Outcomes: `again`, `exhausted`.
    """

    name: ClassVar[str] = "count"
    Params: ClassVar[type[SkillParams]] = CountParams
    outcomes: ClassVar[tuple[str, ...]] = ("again", "exhausted")
    writes: ClassVar[dict[str, str]] = {"key": "int"}

    params: CountParams

    def step(self, ctx: Context) -> str | None:
        p = self.params
        value = ctx.blackboard.get(p.key) or 0
        if not isinstance(value, int) or isinstance(value, bool):
            raise SkillError(f"count: {p.key!r} holds {value!r}, not a count (an integer)")
        value = min(value + 1, p.max + 1)
        ctx.blackboard[p.key] = value
        if value > p.max:
            ctx.log("skill", f"count: {p.key} exhausted ({p.max} passes)")
            return "exhausted"
        return "again"

    def stop(self, ctx: Context) -> None:
        """Counting moves nothing."""

    def explain(self, ctx: Context) -> str | None:
        return f"{self.params.key}: all {self.params.max} passes used"
