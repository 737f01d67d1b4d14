"""`next_task`: take one item at a time from a list on the blackboard, by priority."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any, ClassVar

from pydantic import Field, NonNegativeFloat, PositiveFloat, PositiveInt

from orchestrator.exceptions import SkillError
from orchestrator.world.pose import Pose

from .base import Skill, SkillParams

if TYPE_CHECKING:
    from orchestrator.engine.context import Context

__all__ = ["NextTask", "new_schedule"]

COLOUR_CLASS = {"scene_ref": "colour_class"}


def new_schedule() -> dict[str, Any]:
    """The scheduler's memory before the first task."""
    return {"started": 0, "done": 0, "open": None, "rejected": [], "deferred": []}


class NextTaskParams(SkillParams):
    items: list[Any] = Field(
        description="The candidates (e.g. `$detections`): mappings with a priority field and "
        "a pose."
    )
    priority: list[str] = Field(
        min_length=1,
        description="Values of `priority_by` in the order they are served (first: first); "
        "items of other values are left alone.",
        json_schema_extra=COLOUR_CLASS,
    )
    priority_by: str = Field(default="class", description="Item field ranked by `priority`.")
    pose_field: str = Field(default="pose", description="Item field holding its pose.")
    nearest_to: list[float] | None = Field(
        default=None,
        min_length=3,
        max_length=3,
        description="Tie-break within a priority: nearest (in xy) to this point [m] first "
        "(default: nearest to the hand).",
    )
    min_confidence: float = Field(
        default=0.5, ge=0.0, le=1.0, description="Items with a lower `confidence` are ignored."
    )
    max_attempts: PositiveInt = Field(
        default=2, le=100, description="Attempts at a task before it is rejected."
    )
    match_radius_m: PositiveFloat = Field(
        default=0.03,
        le=1.0,
        description="An item this close (xy) to the open task's item is that item seen again "
        "(its pose re-centres the task) [m]; also how close to a rejected item an item is "
        "ignored.",
    )
    max_tasks: PositiveInt = Field(
        default=10_000, description="Tasks started before the list counts as done (`empty`)."
    )
    state: str = Field(default="schedule", description="Blackboard key of the scheduler's memory.")
    into: str = Field(default="task", description="Blackboard key the chosen item goes to.")
    pose_into: str | None = Field(
        default=None, description="Blackboard key the chosen item's pose goes to."
    )
    duration_s: NonNegativeFloat = Field(default=0.0, description="Time scheduling takes [s].")


class NextTask(Skill):
    """Choose the next task from `items`: the open task again if it failed and its item is
    still there (re-centred on it), else the first item by `priority`, nearest first.

    The scheduler's memory lives on the blackboard under `state` (a dict): tasks `started`
    and `done`, the `open` task (`{task, class, pos, attempts}`) and the `rejected` items.
    `end_task` closes a task; a task still open when `next_task` runs again has failed: it is
    tried again on the nearest item within `match_radius_m` (its `attempts` counted), or,
    after `max_attempts`, rejected — its item is ignored from then on — or, when no item is
    near it any more, dropped from the schedule as lost. Every outcome makes progress: a task
    is retried at most `max_attempts` times and at most `max_tasks` start, so a loop
    `next_task` -> ... -> `next_task` ends. A task `end_task` deferred waits until every other
    item is served, then is tried again on its item (an attempt counted), or rejected after
    `max_attempts`; a rejection names the last attempt's failure.

    Writes the chosen item to `into`, with `task` (its number) and `attempt` added, and its
    pose to `pose_into`. Outcome `next`, or `empty` when no item is left to do.
    """

    name: ClassVar[str] = "next_task"
    Params: ClassVar[type[SkillParams]] = NextTaskParams
    outcomes: ClassVar[tuple[str, ...]] = ("next", "empty")
    writes: ClassVar[dict[str, str]] = {"into": "dict", "pose_into": "pose", "state": "dict"}

    params: NextTaskParams

    def start(self, ctx: Context) -> None:
        self.t0 = ctx.clock

    def step(self, ctx: Context) -> str | None:
        p = self.params
        if ctx.clock - self.t0 < p.duration_s - 1e-9:
            return None
        memory = ctx.blackboard.get(p.state)
        state = new_schedule() if not memory else _copy(memory)
        items = self._unrejected(state, [x for x in map(self._candidate, p.items) if x])
        chosen = self._retry(ctx, state, items)
        items = self._unrejected(state, items)  # without one the retry has just rejected
        while chosen is None:
            if state["started"] >= p.max_tasks:
                ctx.log("skill", f"next_task: max_tasks {p.max_tasks} reached")
                self._close_deferred(ctx, state, [])
                ctx.blackboard[p.state] = state
                return "empty"
            ranked = self._ranked(ctx, state, items)
            if not ranked:
                self._close_deferred(ctx, state, items)
                ctx.log("skill", f"next_task: nothing to do ({len(p.items)} item(s))")
                ctx.blackboard[p.state] = state
                return "empty"
            item, pos = ranked[0]
            waiting = self._deferred_at(state, pos)
            if waiting is not None:  # a task set aside, its turn now that nothing else is left
                state["deferred"].remove(waiting)
                if waiting["attempts"] >= p.max_attempts:
                    self._reject(ctx, state, waiting, pos)
                    items = self._unrejected(state, items)
                    continue
                state["open"] = {
                    **waiting, "pos": pos, "attempts": waiting["attempts"] + 1, "t": ctx.t
                }  # fmt: skip
                ctx.tasks.attempt(ctx, waiting["task"], state["open"]["attempts"])
            else:
                state["started"] += 1
                task = state["started"]
                state["open"] = {
                    "task": task, "class": item[p.priority_by], "pos": pos, "attempts": 1,
                    "t": ctx.t,
                }  # fmt: skip
                ctx.tasks.begin(ctx, task, str(item[p.priority_by]), pos)
            chosen = item, pos
        item, pos = chosen
        open_ = state["open"]
        ctx.blackboard[p.state] = state
        ctx.blackboard[p.into] = {**item, "task": open_["task"], "attempt": open_["attempts"]}
        if p.pose_into is not None:
            ctx.blackboard[p.pose_into] = Pose.coerce(item[p.pose_field])
        return "next"

    def _candidate(self, item: Any) -> tuple[dict, list[float]] | None:
        """`(item, position)` if `item` is one to serve, else None."""
        p = self.params
        if not isinstance(item, dict) or item.get(p.priority_by) not in p.priority:
            return None
        if float(item.get("confidence", 1.0)) < p.min_confidence:
            return None
        try:
            pose = Pose.coerce(item[p.pose_field])
        except (KeyError, TypeError, ValueError) as exc:
            raise SkillError(f"item {item!r} has no pose in {p.pose_field!r}: {exc}") from None
        return item, [float(v) for v in pose.pos]

    def _unrejected(
        self, state: dict, items: list[tuple[dict, list[float]]]
    ) -> list[tuple[dict, list[float]]]:
        rejected = [r["pos"] for r in state["rejected"]]
        r = self.params.match_radius_m
        return [x for x in items if not any(_near(x[1], pos, r) for pos in rejected)]

    def _retry(
        self, ctx: Context, state: dict, items: list[tuple[dict, list[float]]]
    ) -> tuple[dict, list[float]] | None:
        """The open task's item seen again, if the task gets another attempt; else close it."""
        p = self.params
        open_ = state["open"]
        if open_ is None:
            return None
        near = [x for x in items if _near(x[1], open_["pos"], p.match_radius_m)]
        task = open_["task"]
        state["open"] = None
        if not near:
            ctx.tasks.end(ctx, task, "lost", "no longer seen where it was")
            return None
        match = min(near, key=lambda x: math.dist(x[1][:2], open_["pos"][:2]))
        if open_["attempts"] >= p.max_attempts:
            self._reject(ctx, state, open_, match[1])
            return None
        open_ = {**open_, "pos": match[1], "attempts": open_["attempts"] + 1, "t": ctx.t}
        state["open"] = open_
        ctx.tasks.attempt(ctx, task, open_["attempts"])
        return match

    def _reject(self, ctx: Context, state: dict, task: dict, pos: list[float]) -> None:
        """Give up on `task` after its attempts, its item (now at `pos`) ignored from now on."""
        why = f"{task['attempts']} failed attempts (max_attempts {self.params.max_attempts})"
        if task.get("reason"):
            why += f", the last: {task['reason']}"
        state["rejected"].append(
            {"task": task["task"], "class": task["class"], "pos": pos, "reason": why}
        )
        ctx.tasks.end(ctx, task["task"], "rejected", why)

    def _deferred_at(self, state: dict, pos: list[float]) -> dict | None:
        """The deferred task whose item is at `pos` (nearest within the match radius)."""
        r = self.params.match_radius_m
        near = [d for d in state["deferred"] if _near(pos, d["pos"], r)]
        return min(near, key=lambda d: math.dist(pos[:2], d["pos"][:2])) if near else None

    def _close_deferred(
        self, ctx: Context, state: dict, items: list[tuple[dict, list[float]]]
    ) -> None:
        """Nothing left to do: a deferred task whose item is no longer seen is lost."""
        for waiting in list(state["deferred"]):
            if not any(_near(x[1], waiting["pos"], self.params.match_radius_m) for x in items):
                state["deferred"].remove(waiting)
                ctx.tasks.end(ctx, waiting["task"], "lost", "no longer seen where it was")

    def _ranked(
        self, ctx: Context, state: dict, items: list[tuple[dict, list[float]]]
    ) -> list[tuple[dict, list[float]]]:
        """`items` in the order they are served: by `priority`, nearest first; items whose
        task was deferred after all the others."""
        p = self.params
        ref = p.nearest_to if p.nearest_to is not None else ctx.tcp_pos.tolist()
        order = {v: i for i, v in enumerate(p.priority)}
        return sorted(
            items,
            key=lambda x: (
                self._deferred_at(state, x[1]) is not None,
                order[x[0][p.priority_by]],
                math.dist(x[1][:2], ref[:2]),
            ),
        )


def _near(a: list[float], b: list[float], radius: float) -> bool:
    return math.dist(a[:2], b[:2]) <= radius


def _copy(memory: Any) -> dict[str, Any]:
    if not isinstance(memory, dict) or not {"started", "open", "rejected"} <= set(memory):
        raise SkillError(
            f"the scheduler's memory {memory!r} is not one next_task wrote "
            "(keys: started, done, open, rejected)"
        )
    return {
        **memory,
        "rejected": list(memory["rejected"]),
        "deferred": list(memory.get("deferred", [])),
    }
