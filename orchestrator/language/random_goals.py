"""`randomize.blackboard`: blackboard positions drawn per seed (a reach test's target).

```yaml
machine: reach
randomize:
  blackboard:
    target: {x: [0.35, 0.6], y: [-0.25, 0.25], z: [0.3, 0.55]}   # world frame [m]
```

Each seed draws the key's value uniformly from the box, `[x, y, z]`, before the run starts:
the machine reads it like any blackboard value, success checks that follow it (`$target`)
judge against it, and `orchestrator batch` runs as many targets as seeds. The draws come from
a random stream of their own (the seed and a fixed tag), so adding the section changes nothing
else a seed draws. `--set KEY=VALUE` fixes a randomized key. The box is checked as goals are,
before anything moves: all of it inside the scenario's `workspace` guard and within the arm's
reach of its shoulder (both convex, so the eight corners decide: `random_goal_checks.py`).
"""

from __future__ import annotations

import itertools
from typing import Annotated

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, model_validator

from ..world.random_streams import stream

__all__ = ["DrawnValues", "GoalBox", "draw_goals"]


Range = Annotated[
    list[Annotated[float, Field(ge=-10.0, le=10.0)]], Field(min_length=2, max_length=2)
]


class GoalBox(BaseModel):
    """A box a position is drawn from uniformly per seed, world frame."""

    model_config = ConfigDict(defer_build=True, extra="forbid", allow_inf_nan=False)

    x: Range = Field(description="[low, high] [m].")
    y: Range = Field(description="[low, high] [m].")
    z: Range = Field(description="[low, high] [m].")

    @model_validator(mode="after")
    def _ordered(self) -> GoalBox:
        for name in ("x", "y", "z"):
            lo, hi = getattr(self, name)
            if lo > hi:
                raise ValueError(f"{name}: lower bound {lo} is above upper bound {hi}")
        return self

    def corners(self) -> list[np.ndarray]:
        """The eight corners [m]."""
        return [np.array(c) for c in itertools.product(self.x, self.y, self.z)]


class DrawnValues(BaseModel):
    """What a scenario draws per seed besides its scene (objects randomize under `scene`).

    `blackboard: {target: {x: [0.35, 0.6], y: [-0.25, 0.25], z: [0.3, 0.55]}}` draws the key's
    value `[x, y, z]` uniformly from the box for each seed, before the run starts: the machine
    reads it like any blackboard value, a success check with `$target` follows it, and
    `orchestrator batch` runs one target per seed (the bundled `reach_random`). The draws have
    a random stream of their own: adding them changes nothing else a seed draws. `--set
    target=[x, y, z]` fixes the key in every seed. The box is checked as a goal before
    anything moves: inside the `workspace` guard's box and within the arm's reach.
    """

    model_config = ConfigDict(defer_build=True, extra="forbid", allow_inf_nan=False)

    blackboard: dict[str, GoalBox] = Field(
        default_factory=dict,
        description="Blackboard key -> a box its position `[x, y, z]` is drawn from per seed "
        "(e.g. a reach test's `target`); `--set KEY=...` fixes it.",
    )


def draw_goals(randomize: DrawnValues, seed: int) -> dict[str, list[float]]:
    """The positions drawn for `seed`, key -> [x, y, z] [m] (in the order of `randomize`)."""
    if not randomize.blackboard:
        return {}
    rng = stream(seed, "blackboard_goals")
    return {
        key: [float(rng.uniform(lo, hi)) for lo, hi in (box.x, box.y, box.z)]
        for key, box in randomize.blackboard.items()
    }
