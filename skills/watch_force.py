"""`watch_force`: a monitor that ends its state when the wrist feels an unexpected force.

Run beside a motion toward contact, in a parallel state with `rule: first`:

```yaml
APPROACH:
  rule: first
  parallel:
    motion: {skill: move, with: {target: $object_pose}}
    feel: {skill: watch_force, with: {max_force_n: 15}}
  transitions: {reached: CLOSE, unreachable: FAILED, timeout: FAILED, contact: BACK_OFF}
```

The motion stops where it is and the flow decides (back off, look again, try another way):
a finger coming down on a neighbour is felt at a few newtons, long before the `contact_force`
guard's limit aborts the run. The guard stays the last line, not the first.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any, ClassVar

from pydantic import BaseModel, ConfigDict, Field, NonNegativeFloat, PositiveFloat

from .base import SCENE_TARGET, Skill, SkillParams
from .targets import resolve_target

if TYPE_CHECKING:
    from orchestrator.engine.context import Context

__all__ = ["WatchForce"]


class Band(BaseModel):
    """A height band over which the watch is more sensitive: a guarded approach's slow last
    stretch (`move`'s `guarded_from_m` / `guarded_to_m`), where a finger may land on the
    object's top."""

    model_config = ConfigDict(defer_build=True, extra="forbid")

    target: Any = Field(
        description="What the heights are measured from (the motion's target: a pose, an "
        "object or marker name, or `[x, y, z]` [m]).",
        json_schema_extra=SCENE_TARGET,
    )
    offset: list[float] = Field(
        default_factory=lambda: [0.0, 0.0, 0.0],
        min_length=3,
        max_length=3,
        description="Added to the target's position, world frame [m] (the motion's `offset`).",
    )
    from_m: NonNegativeFloat = Field(description="Top of the band above it [m].")
    to_m: NonNegativeFloat = Field(description="Bottom of the band above it [m].")
    max_force_n: PositiveFloat = Field(
        le=1000.0, description="The threshold while the TCP is in the band [N]."
    )


class WatchForceParams(SkillParams):
    max_force_n: PositiveFloat = Field(
        default=15.0,
        le=1000.0,
        description="Wrist force (hand weight removed) that counts as an unexpected contact [N].",
    )
    duration_s: NonNegativeFloat = Field(
        default=0.0,
        le=10.0,
        description="How long the force must stay above `max_force_n` [s] (0: one control tick).",
    )
    band: Band | None = Field(
        default=None,
        description="A height band of the TCP with a lower threshold (a guarded approach's "
        "slow stretch); outside it, `max_force_n`.",
    )


class WatchForce(Skill):
    """Watch the wrist force every control tick; `contact` once it stays above `max_force_n`
    for `duration_s`. It commands nothing: the motion it watches is stopped by the state
    ending (a parallel state with `rule: first`).

    Outcomes: `contact` (the only one: a watch that sees nothing runs until its state ends).
    The peak force is in the transition's detail.
    """

    name: ClassVar[str] = "watch_force"
    Params: ClassVar[type[SkillParams]] = WatchForceParams
    outcomes: ClassVar[tuple[str, ...]] = ("contact",)
    explained: ClassVar[tuple[str, ...]] = ("contact",)

    params: WatchForceParams

    def start(self, ctx: Context) -> None:
        self.above_since: float | None = None
        self.peak_n = 0.0
        self.limit_n = self.params.max_force_n
        """The threshold the last reading was held to [N]."""
        self.z_band: tuple[float, float] | None = None
        band = self.params.band
        if band is not None:
            z = float(resolve_target(ctx, band.target).pos[2]) + band.offset[2]
            self.z_band = (z + min(band.to_m, band.from_m), z + max(band.to_m, band.from_m))

    def step(self, ctx: Context) -> str | None:
        p = self.params
        force = math.sqrt(ctx.wrist_force_norm_sq())
        limit = p.max_force_n
        if self.z_band is not None and p.band is not None:
            if self.z_band[0] <= float(ctx.tcp_pos[2]) <= self.z_band[1]:
                limit = min(limit, p.band.max_force_n)
        if not force > limit:  # a NaN reading is sensor_health's to judge
            self.above_since = None
            return None
        self.peak_n = max(self.peak_n, force)
        self.limit_n = limit
        if self.above_since is None:
            self.above_since = ctx.clock
        if ctx.clock - self.above_since < p.duration_s - 1e-9:
            return None
        ctx.log(
            "skill",
            f"watch_force: {force:.1f} N at the wrist (max_force_n {limit:g})",
            level="WARN",
        )
        return "contact"

    def stop(self, ctx: Context) -> None:
        """Nothing to leave behind: the watch commands nothing (the motion beside it holds)."""

    def explain(self, ctx: Context) -> str | None:
        limit = getattr(self, "limit_n", self.params.max_force_n)
        where = ""
        if limit < self.params.max_force_n:
            where = ", the guarded stretch's"
        return (
            f"unexpected contact: {self.peak_n:.1f} N at the wrist (max_force_n {limit:g}{where})"
        )
