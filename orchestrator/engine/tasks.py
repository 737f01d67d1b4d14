"""The task log of a sorting run: one entry per parcel, judged against the simulator's truth.

The flow's task skills (`next_task`, `end_task`) report what the flow believes: which
detection a task is about, its attempts, and how the flow ended it (`placed`, `rejected`
with a reason, or `lost` from view). The log ties each task to the true parcel nearest to its
detection when it starts, and at the end of the run judges every parcel by where it really is:

* `sorted`: in the bin of its class; `missorted`: in another bin;
* `rejected`: still in the pick area, rejected by the flow (its reason kept);
* `dropped`: anywhere else (on the floor, on the table outside the area, on a bin's rim);
* `unsorted`: still in the pick area and never rejected — the flow left it behind.

On a conveyor (`scene.conveyor`) a body carries one parcel after another: the log keys its
entries by the parcel's id (`parcel_0007`), judges a parcel when its body is taken back to the
feed (and the rest at the end), and counts the belt as the pick area. An entry is a slotted
dataclass of a few fields, so a shift of 1,000 parcels keeps ~1,000 small objects.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

from ..perception.truth import MATCH_RADIUS_M

if TYPE_CHECKING:
    from ..language.scenario import Scenario
    from ..world.pose import Pose
    from ..world.world import World


class Context(Protocol):
    """What the task log reads of the running episode (the engine's `Context` has it; named
    here so that context.py, which holds a TaskLog, and this module import no cycle)."""

    world: World
    scenario: Scenario

    @property
    def t(self) -> float: ...

    def log(self, kind: str, message: str, level: str = "INFO", **data: Any) -> None: ...

    def object_pose(self, name: str) -> Pose: ...


__all__ = ["OUTCOMES", "TaskEntry", "TaskLog", "metrics"]

OUTCOMES = ("sorted", "missorted", "dropped", "rejected", "unsorted")
"""Every outcome a parcel can end with, best first."""

_AREA_MARGIN_M = 0.03
"""A parcel this far outside the pick area still counts as in it (pushed aside) [m]."""


@dataclass(slots=True)
class TaskEntry:
    """What happened to one parcel.

    Attributes:
        id: The parcel's scene name (on a conveyor: its id, `parcel_0007`).
        true_class: Its class in the simulator.
        detected: The class perception reported when its task started (None: never scheduled).
        bin: The bin the flow took it to (None: none).
        attempts: Grasps tried on it.
        flow: How the flow ended its last task: placed, rejected, lost (None: never ended).
        reason: Why it was rejected (the flow's words).
        start_t: Simulated time its first task started [s].
        end_t: Simulated time its last task ended [s].
        outcome: The verdict at the end of the run (one of `OUTCOMES`).
    """

    id: str
    true_class: str
    detected: str | None = None
    bin: str | None = None
    attempts: int = 0
    flow: str | None = None
    reason: str | None = None
    start_t: float | None = None
    end_t: float | None = None
    outcome: str | None = None

    def to_dict(self) -> dict[str, Any]:
        """The form of the run JSON's `tasks`."""
        out: dict[str, Any] = {
            "id": self.id,
            "class": self.true_class,
            "detected_class": self.detected,
            "bin": self.bin,
            "attempts": self.attempts,
            "outcome": self.outcome,
            "start_t": None if self.start_t is None else round(self.start_t, 4),
            "end_t": None if self.end_t is None else round(self.end_t, 4),
        }
        if self.reason is not None:
            out["reason"] = self.reason
        return out


@dataclass
class TaskLog:
    """Tasks as the flow reports them, tied to the true parcels (one per run, on `Context`)."""

    entries: dict[str, TaskEntry] = field(default_factory=dict)
    by_task: dict[int, str | None] = field(default_factory=dict)
    """Task number -> the parcel it is about (None: no parcel near the detection)."""
    ghost_tasks: int = 0
    """Tasks whose detection matched no true parcel."""
    final: list[TaskEntry] | None = None
    """Every parcel's entry once `finalize` judged them."""

    def begin(self, ctx: Context, task: int, detected: str, pos: list[float]) -> str | None:
        """Task `task` starts on the detection of class `detected` at `pos` [m] (its first
        attempt). Returns the parcel it is about (None: no parcel within the match radius)."""
        body = _nearest_parcel(ctx, pos)
        parcel = None if body is None else _parcel_of(ctx, body)
        self.by_task[task] = parcel
        if body is None or parcel is None:
            self.ghost_tasks += 1
            ctx.log("task", f"task {task}: {detected} detection at {_xy(pos)} is no parcel")
            return None
        e = self._entry(ctx, body)
        e.detected = detected
        e.attempts += 1
        if e.start_t is None:
            e.start_t = ctx.t
        ctx.log("task", f"task {task}: {parcel} ({detected}) at {_xy(pos)}, attempt {e.attempts}")
        return parcel

    def attempt(self, ctx: Context, task: int, attempt: int) -> None:
        """Task `task` tries again (attempt number `attempt` of the task)."""
        parcel = self.by_task.get(task)
        if parcel is not None:
            self.entries[parcel].attempts += 1
        ctx.log("task", f"task {task}: {parcel or 'no parcel'}, attempt {attempt}")

    def end(
        self, ctx: Context, task: int, flow: str, reason: str | None = None, bin: str | None = None
    ) -> None:
        """The flow ends task `task` with `flow` (placed, rejected, lost)."""
        parcel = self.by_task.get(task)
        why = f": {reason}" if reason else ""
        ctx.log("task", f"task {task}: {parcel or 'no parcel'} {flow}{why}")
        if parcel is None:
            return
        e = self.entries[parcel]
        e.flow, e.end_t = flow, ctx.t
        e.reason = reason if flow == "rejected" else None
        if bin is not None:
            e.bin = bin

    def judge(self, ctx: Context, body: str) -> TaskEntry:
        """Judge the parcel `body` carries by where it is now (its verdict is final)."""
        e = self._entry(ctx, body)
        e.outcome = _verdict(ctx, e, body)
        if e.outcome == "dropped" and e.flow == "rejected":
            e.reason = None
        ctx.log("task", f"{e.id} ({e.true_class}): {e.outcome}")
        return e

    def finalize(self, ctx: Context) -> list[TaskEntry]:
        """Judge every parcel by where it is now; the entries, in parcel order (kept in
        `final`)."""
        belt = ctx.world.conveyor
        if belt is None:
            for parcel in ctx.world.parcel_classes:
                self.judge(ctx, parcel)
            self.final = [self.entries[p] for p in ctx.world.parcel_classes]
        else:
            for body, _ in belt.active():
                self.judge(ctx, body)
            self.final = sorted(self.entries.values(), key=lambda e: e.id)
        return self.final

    def _entry(self, ctx: Context, body: str) -> TaskEntry:
        parcel = _parcel_of(ctx, body) or body
        e = self.entries.get(parcel)
        if e is None:
            e = self.entries[parcel] = TaskEntry(parcel, ctx.world.parcel_classes[body])
        return e


def metrics(entries: list[TaskEntry], end_t: float) -> dict[str, Any]:
    """Counts per outcome, `parcels_per_hour` (sorted per simulated hour up to `end_t` [s]) and
    the percentiles of the sorted parcels' cycle time (first task start to placing) [s]."""
    out: dict[str, Any] = {"parcels": len(entries)}
    for outcome in OUTCOMES:
        out[outcome] = sum(1 for e in entries if e.outcome == outcome)
    out["parcels_per_hour"] = round(out["sorted"] / end_t * 3600.0, 1) if end_t > 0 else 0.0
    cycles = [
        e.end_t - e.start_t
        for e in entries
        if e.outcome == "sorted" and e.start_t is not None and e.end_t is not None
    ]
    if cycles:
        out["parcel_cycle_s"] = {
            f"p{q}": round(float(np.percentile(cycles, q)), 4) for q in (50, 90, 99)
        }
    return out


def _xy(pos: list[float]) -> list[float]:
    return [round(float(v), 3) for v in pos[:2]]


def _parcel_of(ctx: Context, body: str) -> str | None:
    """The parcel `body` is (on a conveyor: carries now; None: a parked body)."""
    belt = ctx.world.conveyor
    return body if belt is None else belt.parcel_id(body)


def _nearest_parcel(ctx: Context, pos: list[float]) -> str | None:
    best, best_d = None, MATCH_RADIUS_M
    for name in ctx.world.parcel_classes:
        d = math.dist(ctx.object_pose(name).pos[:2], pos[:2])
        if d <= best_d:
            best, best_d = name, d
    return best


def _verdict(ctx: Context, e: TaskEntry, body: str) -> str:
    pos = ctx.object_pose(body).pos
    scene = ctx.scenario.scene
    top = scene.table.height
    for b in scene.bins:
        hx, hy = b.inner_half()
        # inside the walls, at any height: on the floor or on the parcels already in it
        if abs(pos[0] - b.xy[0]) <= hx and abs(pos[1] - b.xy[1]) <= hy and pos[2] > top:
            e.bin = b.name
            return "sorted" if b.class_ == e.true_class else "missorted"
    belt = ctx.world.conveyor
    if belt is not None:  # the belt is the pick area; a rejected parcel went off its end
        if e.flow == "rejected":
            return "rejected"
        half_h = float(ctx.world.objects[body].half_size[2])
        return "unsorted" if belt.on_belt(pos, half_h) else "dropped"
    p = scene.parcels
    if p is not None and pos[2] > top:
        (ax, ay), (sx, sy) = p.area_center_xy, p.area_size_xy
        if (
            abs(pos[0] - ax) <= sx / 2 + _AREA_MARGIN_M
            and abs(pos[1] - ay) <= sy / 2 + _AREA_MARGIN_M
        ):
            return "rejected" if e.flow == "rejected" else "unsorted"
    return "dropped"
