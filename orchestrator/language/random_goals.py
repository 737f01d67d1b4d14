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
reach of its shoulder (both convex, so the eight corners decide).
"""

from __future__ import annotations

import itertools
from typing import Annotated, Any

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from ..guards import GUARDS
from ..robots import ROBOTS
from .blackboard_types import check_type
from .diagnostics import Diagnostic
from .machine import guard_entries
from .yamlio import SourceMap

__all__ = ["BLACKBOARD_STREAM", "DrawnValues", "GoalBox", "check_random_goals", "draw_goals"]

BLACKBOARD_STREAM = 0xB1AC_B0A2
"""Tag of the random stream the blackboard draws come from (`default_rng([seed, tag])`)."""

Range = Annotated[
    list[Annotated[float, Field(ge=-10.0, le=10.0)]], Field(min_length=2, max_length=2)
]


class GoalBox(BaseModel):
    """A box a position is drawn from uniformly per seed, world frame."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)

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

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)

    blackboard: dict[str, GoalBox] = Field(
        default_factory=dict,
        description="Blackboard key -> a box its position `[x, y, z]` is drawn from per seed "
        "(e.g. a reach test's `target`); `--set KEY=...` fixes it.",
    )


def draw_goals(randomize: DrawnValues, seed: int) -> dict[str, list[float]]:
    """The positions drawn for `seed`, key -> [x, y, z] [m] (in the order of `randomize`)."""
    if not randomize.blackboard:
        return {}
    rng = np.random.default_rng([seed, BLACKBOARD_STREAM])
    return {
        key: [float(rng.uniform(lo, hi)) for lo, hi in (box.x, box.y, box.z)]
        for key, box in randomize.blackboard.items()
    }


def check_random_goals(
    randomize: DrawnValues,
    types: dict[str, str],
    guards: list[Any] | dict[str, Any],
    robot: str,
    base_pos: list[float],
    source: SourceMap,
) -> list[Diagnostic]:
    """Each randomized key is a blackboard key the machine declares as a position, and its box
    lies inside the workspace guard's box and within the arm's reach.

    Args:
        randomize: The scenario's `randomize:`.
        types: Declared type of each blackboard key of the machine.
        guards: The scenario's `guards:` (a `workspace` entry bounds the box).
        robot: The robot's name (its shoulder and reach).
        base_pos: Where the robot stands [m].
        source: The scenario file (for messages).
    """
    out = []
    box_of = _workspace(guards)
    cls = ROBOTS.get(robot)
    for key, box in randomize.blackboard.items():
        at = ("randomize", "blackboard", key)
        if key not in types:
            why = f"the machine has no blackboard key {key!r}"
            out.append(source.diag(at, why, tuple(sorted(types))))
            continue
        if not check_type([0.0, 0.0, 0.0], types[key]):
            why = f"{key!r} is a {types[key]}: only a position ([x, y, z]) is drawn from a box"
            out.append(source.diag(at, why))
            continue
        corners = box.corners()
        if box_of is not None:
            lo, hi = box_of
            outside = [c for c in corners if np.any(c < lo) or np.any(c > hi)]
            if outside:
                out.append(
                    source.diag(
                        at,
                        f"can draw {_fmt(outside[0])}, outside the workspace guard's box "
                        f"{_fmt(lo)} .. {_fmt(hi)} m: narrow the ranges",
                    )
                )
                continue
        if cls is not None and not cls.base_joints:  # a mobile base drives to its goals
            shoulder = cls().shoulder(np.zeros(len(cls.arm_joints)), np.asarray(base_pos))
            far = max(corners, key=lambda c: float(np.linalg.norm(c - shoulder)))
            dist = float(np.linalg.norm(far - shoulder))
            if dist > cls.reach_m:
                out.append(
                    source.diag(
                        at,
                        f"can draw {_fmt(far)}, {dist:.3f} m from the {robot}'s shoulder, "
                        f"beyond its reach ({cls.reach_m} m): narrow the ranges",
                    )
                )
    return out


def _workspace(guards: list[Any] | dict[str, Any]) -> tuple[np.ndarray, np.ndarray] | None:
    """The `workspace` guard's box, if the scenario has one (its parameters are valid here)."""
    for _, name, params in guard_entries(guards):
        if name == "workspace" and name in GUARDS:
            try:
                p: Any = GUARDS[name].Params.model_validate(params)
            except ValidationError:
                return None  # reported with the guards
            return np.asarray(p.min, float), np.asarray(p.max, float)
    return None


def _fmt(point: np.ndarray) -> str:
    return "[" + ", ".join(f"{v:g}" for v in point) + "]"
