"""Conveyor skills: `wait_for_parcel` (the light barrier) and `pass_parcel` (let one go by)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, ClassVar

from pydantic import Field, NonNegativeFloat, PositiveFloat

from orchestrator.exceptions import SkillError

from .base import Skill, SkillParams

if TYPE_CHECKING:
    from orchestrator.engine.context import Context
    from orchestrator.world.conveyor import ConveyorBelt

__all__ = ["PassParcel", "WaitForParcel"]


def _belt(ctx: Context, skill: str) -> ConveyorBelt:
    belt = ctx.world.conveyor
    if belt is None:
        raise SkillError(
            f"{skill}: the scenario has no conveyor: add `scene.conveyor` (docs/sorting.md)"
        )
    return belt


class WaitForParcelParams(SkillParams):
    settle_s: NonNegativeFloat = Field(
        default=0.1,
        le=5.0,
        description="The beam stays blocked, the belt stopped, this long before `arrived` [s]: "
        "the parcel comes to rest on the still belt.",
    )
    timeout_s: PositiveFloat = Field(
        default=30.0, le=3600.0, description="No parcel and no end of the shift within [s]."
    )
    into: str | None = Field(
        default=None,
        description="Blackboard key that gets the belt's state: `{fed, shift, blocked}`.",
    )


class WaitForParcel(Skill):
    """Wait at the conveyor's light barrier for the next parcel.

    Outcomes: `arrived` (a parcel broke the beam and the belt has stopped under it for
    `settle_s`), `shift_over` (every parcel of the shift was fed and the belt is empty),
    `timeout` (neither within `timeout_s`: the feed starved or the belt is blocked upstream).
    """

    name: ClassVar[str] = "wait_for_parcel"
    Params: ClassVar[type[SkillParams]] = WaitForParcelParams
    outcomes: ClassVar[tuple[str, ...]] = ("arrived", "shift_over", "timeout")
    writes: ClassVar[dict[str, str]] = {"into": "dict"}
    needs_scene: ClassVar[tuple[str, ...]] = ("conveyor",)

    params: WaitForParcelParams

    def start(self, ctx: Context) -> None:
        self.belt = _belt(ctx, self.name)
        self.t0 = ctx.clock
        self.since: float | None = None

    def step(self, ctx: Context) -> str | None:
        p, belt = self.params, self.belt
        if p.into is not None:
            state: dict[str, Any] = {"fed": belt.fed, "shift": belt.c.parcels}
            ctx.blackboard[p.into] = {**state, "blocked": belt.blocked}
        if belt.waiting:
            self.since = ctx.clock if self.since is None else self.since
            if ctx.clock - self.since >= p.settle_s - 1e-9:
                return "arrived"
            return None
        self.since = None
        if belt.shift_over:
            ctx.log("skill", f"wait_for_parcel: shift over, {belt.fed} parcels fed")
            return "shift_over"
        if ctx.clock - self.t0 > p.timeout_s:
            ctx.log(
                "skill",
                f"wait_for_parcel: no parcel in {p.timeout_s:g} s ({belt.fed}/{belt.c.parcels} "
                f"fed, belt {'running' if belt.running else 'stopped'})",
                level="WARNING",
            )
            return "timeout"
        return None


class PassParcelParams(SkillParams):
    timeout_s: PositiveFloat = Field(
        default=5.0, le=600.0, description="The beam must clear within [s]."
    )
    state: str | None = Field(
        default="schedule",
        description="Blackboard key of `next_task`'s memory: its rejected items (all in the "
        "pick zone) are forgotten once the parcel has gone, so the next parcel there is served.",
    )


class PassParcel(Skill):
    """Run the belt through the blocked light barrier until the beam is clear: the parcel in
    the pick zone (a rejected one) goes on and off the belt's end. Outcome `passed`, or
    `timeout` when the beam stays blocked (the hand in it, a parcel stuck)."""

    name: ClassVar[str] = "pass_parcel"
    Params: ClassVar[type[SkillParams]] = PassParcelParams
    outcomes: ClassVar[tuple[str, ...]] = ("passed", "timeout")
    writes: ClassVar[dict[str, str]] = {"state": "dict"}
    needs_scene: ClassVar[tuple[str, ...]] = ("conveyor",)

    params: PassParcelParams

    def start(self, ctx: Context) -> None:
        self.belt = _belt(ctx, self.name)
        self.t0 = ctx.clock
        self.belt.pass_through()

    def step(self, ctx: Context) -> str | None:
        p = self.params
        if not self.belt.passing:
            memory = ctx.blackboard.get(p.state) if p.state is not None else None
            if p.state is not None and isinstance(memory, dict):
                ctx.blackboard[p.state] = {**memory, "rejected": []}
            return "passed"
        if ctx.clock - self.t0 > p.timeout_s:
            return "timeout"
        return None

    def stop(self, ctx: Context) -> None:
        self.belt.passing = False
