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
from typing import TYPE_CHECKING, ClassVar

from pydantic import Field, NonNegativeFloat, PositiveFloat

from .base import Skill, SkillParams

if TYPE_CHECKING:
    from orchestrator.engine.context import Context

__all__ = ["WatchForce"]


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

    def step(self, ctx: Context) -> str | None:
        p = self.params
        force = math.sqrt(ctx.wrist_force_norm_sq())
        if not force > p.max_force_n:  # a NaN reading is sensor_health's to judge
            self.above_since = None
            return None
        self.peak_n = max(self.peak_n, force)
        if self.above_since is None:
            self.above_since = ctx.clock
        if ctx.clock - self.above_since < p.duration_s - 1e-9:
            return None
        ctx.log(
            "skill",
            f"watch_force: {force:.1f} N at the wrist (max_force_n {p.max_force_n:g})",
            level="WARN",
        )
        return "contact"

    def stop(self, ctx: Context) -> None:
        """Nothing to leave behind: the watch commands nothing (the motion beside it holds)."""

    def explain(self, ctx: Context) -> str | None:
        limit = self.params.max_force_n
        return f"unexpected contact: {self.peak_n:.1f} N at the wrist (max_force_n {limit:g})"
