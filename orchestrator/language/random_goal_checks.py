"""The box of a randomized goal (`randomize.blackboard`) checked as goals are, before anything
moves: a position key of the machine, inside the scenario's `workspace` guard and within the
arm's reach. Both regions are convex, so the box's eight corners decide.

(Apart from `random_goals.py`, which the scenario model imports: these checks need the guards,
whose base module refers to the engine's context.)
"""

from __future__ import annotations

from typing import Any

import numpy as np
from pydantic import ValidationError

from ..guards import GUARDS
from ..robots import ROBOTS
from .blackboard_types import check_type
from .diagnostics import Diagnostic
from .machine import guard_entries
from .random_goals import DrawnValues
from .yamlio import SourceMap

__all__ = ["check_random_goals"]


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
