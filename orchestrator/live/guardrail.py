"""Guarded goals: every goal from outside is checked before anything moves.

A goal is a blackboard value the task's machine declares as a position (`vec3`, `pose`, or
`any` holding three numbers, like `place_at`). It must be finite, inside the scenario's
workspace box (its `workspace` guard), not below the table top nor inside a scene object
(the no-go zones), and reachable: a damped IK solve on a copy of the robot's model,
from the arm's current configuration with the gripper pointing down, converges to within
`REACH_TOL_M`. A goal that fails any check rejects the whole command with the reason; the
robot is left as it was.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..engine.reach import ik_miss
from ..language.load import LoadedScenario
from ..language.machine import guard_entries
from ..language.scenario_checks import goal_keys
from ..world.world import World

__all__ = ["REACH_TOL_M", "GoalRejected", "check_goals", "goals_of"]

REACH_TOL_M = 0.002
"""A goal is reachable if the IK gets the TCP this close to it [m]."""


class GoalRejected(Exception):
    """A goal failed a check: the message says which goal and why."""


def _as_point(value: Any) -> np.ndarray | None:
    """[x, y, z], or a pose mapping's `pos` -> a float array; None if not a position."""
    if isinstance(value, dict) and "pos" in value:
        value = value["pos"]
    if (
        isinstance(value, (list, tuple))
        and len(value) == 3
        and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value)
    ):
        return np.asarray(value, float)
    return None


def goals_of(loaded: LoadedScenario, keys: list[str]) -> dict[str, np.ndarray]:
    """The values set by `keys` that the machine moves to (a motion skill's `target` reads
    them) and that are positions: the goals to check. Offsets and names are not goals."""
    targets = goal_keys(loaded.machine)
    out = {}
    for k in keys:
        point = _as_point(loaded.scenario.blackboard.get(k))
        if point is not None and k in targets:
            out[k] = point
    return out


def check_goals(
    loaded: LoadedScenario, keys: list[str], world: World, q_arm: np.ndarray
) -> dict[str, np.ndarray]:
    """Check every goal set by `keys` (the `--set` keys of a command).

    Args:
        loaded: The task, loaded with its `--set` values.
        keys: The blackboard keys the command set.
        world: The session's world (its scene, read only).
        q_arm: The arm's current joint angles [rad], the IK's seed.

    Returns:
        The goals checked, key -> position [m].

    Raises:
        GoalRejected: Naming the first goal that fails and why.
    """
    goals = goals_of(loaded, keys)
    targets = goal_keys(loaded.machine)
    for k in (k for k in keys if k in targets):
        value = loaded.scenario.blackboard.get(k)
        flat = value.get("pos", value) if isinstance(value, dict) else value
        if isinstance(flat, (list, tuple)) and any(
            isinstance(v, float) and not math.isfinite(v) for v in flat
        ):
            raise GoalRejected(f"{k} = {flat}: not finite")
    scn = loaded.scenario
    box = _workspace(scn)
    for k, p in goals.items():
        where = f"{k} = {np.round(p, 4).tolist()}"
        if box is not None:
            lo, hi = box
            if np.any(p < lo) or np.any(p > hi):
                raise GoalRejected(
                    f"{where}: outside the workspace [{lo.tolist()} .. {hi.tolist()}] m"
                )
        _check_clear(where, p, world)
        _check_reach(where, p, world, q_arm)
    return goals


def _workspace(scn) -> tuple[np.ndarray, np.ndarray] | None:
    for _, name, params in guard_entries(scn.guards):
        if name == "workspace":
            lo = params.get("min", [-1.0, -1.0, 0.0])
            hi = params.get("max", [1.0, 1.0, 1.5])
            return np.asarray(lo, float), np.asarray(hi, float)
    return None


def _check_clear(where: str, p: np.ndarray, world: World) -> None:
    table = world.scenario.scene.table
    cx, cy = table.center_xy
    sx, sy = table.size_xy
    if abs(p[0] - cx) <= sx / 2 and abs(p[1] - cy) <= sy / 2 and p[2] < table.height:
        raise GoalRejected(f"{where}: inside the table (its top is at z = {table.height} m)")
    data = world.data
    for name, h in world.objects.items():
        rot = data.xmat[h.body_id].reshape(3, 3)
        extent = np.abs(rot) @ h.half_size  # the object's axis-aligned bounding box
        centre = data.xpos[h.body_id]
        if np.all(np.abs(p - centre) < extent):
            raise GoalRejected(f"{where}: inside scene object {name!r} (a no-go zone)")


def _check_reach(where: str, p: np.ndarray, world: World, q_arm: np.ndarray) -> None:
    miss = ik_miss(world, q_arm, p, REACH_TOL_M)
    if miss > REACH_TOL_M:
        raise GoalRejected(
            f"{where}: unreachable (the IK gets the TCP no closer than {miss * 1000:.1f} mm, "
            f"tolerance {REACH_TOL_M * 1000:.0f} mm)"
        )
