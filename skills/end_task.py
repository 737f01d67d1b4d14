"""`end_task`: close (or fail) the task `next_task` opened."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, ClassVar, Literal

from pydantic import Field, model_validator

from orchestrator.exceptions import SkillError

from .base import Skill, SkillParams

if TYPE_CHECKING:
    from orchestrator.engine.context import Context

__all__ = ["EndTask"]


class EndTaskParams(SkillParams):
    outcome: Literal["done", "failed", "deferred", "rejected"] = Field(
        description="`done`: the task is finished; `failed`: this attempt failed (the next "
        "`next_task` tries again or rejects it); `deferred`: this attempt failed, and its item "
        "waits until nothing else is left (something around it may go first); `rejected`: "
        "give up on it now."
    )
    reason: str | None = Field(
        default=None,
        description="Why it failed or was rejected (kept in the task log). `{detail}` is "
        "replaced by why the last state that failed in this attempt ended (its transition's "
        "detail, e.g. a move's residual), or by `-` when none said.",
    )
    bin: str | None = Field(default=None, description="Where a done task put its item.")
    state: str = Field(default="schedule", description="Blackboard key of the scheduler's memory.")

    @model_validator(mode="after")
    def _reason(self) -> EndTaskParams:
        if self.outcome == "rejected" and not self.reason:
            raise ValueError("a rejected task needs a `reason`")
        return self


class EndTask(Skill):
    """End the open task of the scheduler under `state`: `done` counts it finished,
    `rejected` records its item as rejected (with `reason`) so that `next_task` leaves it
    alone, `failed` leaves it open for `next_task` to retry, `deferred` sets it aside for
    `next_task` to retry once nothing else is left. Outcome `ended`; ending with no open task
    is a mistake in the flow and stops the run with a message."""

    name: ClassVar[str] = "end_task"
    Params: ClassVar[type[SkillParams]] = EndTaskParams
    outcomes: ClassVar[tuple[str, ...]] = ("ended",)
    writes: ClassVar[dict[str, str]] = {"state": "dict"}

    params: EndTaskParams

    def step(self, ctx: Context) -> str | None:
        p = self.params
        memory: Any = ctx.blackboard.get(p.state)
        open_ = memory.get("open") if isinstance(memory, dict) else None
        if open_ is None:
            raise SkillError(
                f"end_task: no open task in {p.state!r}: run `next_task` (state: {p.state}) first"
            )
        state = {**memory, "rejected": list(memory["rejected"])}
        task = open_["task"]
        reason = _with_detail(ctx, p.reason, float(open_.get("t", 0.0)))
        if p.outcome in ("failed", "deferred"):
            state["open"] = {**open_, "reason": reason}
            ctx.log("task", f"task {task}: attempt {open_['attempts']} failed: {reason or '-'}")
            if p.outcome == "deferred":
                state["open"] = None
                state["deferred"] = [*memory.get("deferred", []), {**open_, "reason": reason}]
        elif p.outcome == "done":
            state["open"] = None
            state["done"] = int(state.get("done", 0)) + 1
            ctx.tasks.end(ctx, task, "placed", bin=p.bin)
        else:
            state["open"] = None
            state["rejected"].append(
                {"task": task, "class": open_["class"], "pos": open_["pos"], "reason": reason}
            )
            ctx.tasks.end(ctx, task, "rejected", reason)
        ctx.blackboard[p.state] = state
        return "ended"


def _with_detail(ctx: Context, reason: str | None, since: float) -> str | None:
    """`reason` with `{detail}` replaced by the detail of the last transition since `since`
    [s] that has one (why a state of this attempt failed)."""
    if reason is None or "{detail}" not in reason:
        return reason
    detail = "-"
    for event in reversed(ctx.events):
        if event.t < since - 1e-9:
            break
        rec = (event.data or {}).get("transition") if event.kind == "transition" else None
        if rec and rec.get("detail"):
            detail = str(rec["detail"])
            break
    return reason.replace("{detail}", detail)
