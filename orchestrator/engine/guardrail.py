"""Guarded goals: every value from outside that becomes a position is checked before anything
moves.

A value set by a command (a live `run --set`, a planner's proposal, the `--set` of
`orchestrator run`, `batch` and `faults` through `prepare`, engine/prepare.py) takes part in a
position wherever the machine uses it as a motion's target, as the offset added to one
(`move`'s `offset`, a `via` point's: a hover height), or as a position hint (language/inputs.py,
`PoseUse`). Each such position must be:

* finite (the value itself, before anything else);
* inside the scenario's workspace box (its `workspace` guard);
* for a motion: not below the table top nor inside a scene object (the no-go zones; the object
  a target is taken from is what the hand goes to grasp, not a zone), and reachable — a damped
  IK solve on a copy of the robot's model, from the arm's current configuration with the
  gripper pointing down, converges to within `REACH_TOL_M`;
* for a position hint: near something — a scene object within the hint's radius, in the
  horizontal plane.

A target that is only known once the machine runs (a pose a search writes) is taken where
every object it could be is now, so an offset added to it is checked against each of them.
A value that fails any check rejects the whole command with the reason; the robot is left as
it was.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from typing import Any

import numpy as np

from ..language.blackboard_types import all_finite
from ..language.inputs import HINT, PoseUse, pose_uses
from ..language.load import LoadedScenario
from ..language.loading import initial_values
from ..language.refs import parse_ref
from ..language.scenario_checks import workspace_box
from ..world.world import World
from .reach import ik_miss

__all__ = ["REACH_TOL_M", "GoalRejected", "check_goals", "is_finite", "posed_keys"]

REACH_TOL_M = 0.002
"""A goal is reachable if the IK gets the TCP this close to it [m]."""

_Base = tuple[np.ndarray, str, str | None]
"""A position a target stands for: (point [m], how it was found, the object it is on)."""


class GoalRejected(Exception):
    """A goal failed a check: the message says which value, where it is used, and why."""


def is_finite(value: Any) -> bool:
    """No NaN or infinity in `value`, nor a text that reads as one (`NaN`, `inf`)."""
    if isinstance(value, str):
        try:
            return math.isfinite(float(value))
        except ValueError:
            return True
    return all_finite(value)


def posed_keys(loaded: LoadedScenario, keys: Iterable[str]) -> list[str]:
    """The keys among `keys` that take part in a position (a target, an offset, a hint)."""
    used = {k for use in pose_uses(loaded.machine) for k in use.keys()}
    return [k for k in dict.fromkeys(keys) if k in used]


def check_goals(
    loaded: LoadedScenario, keys: Iterable[str], world: World, q_arm: np.ndarray
) -> dict[str, list[np.ndarray]]:
    """Check every position the values set by `keys` take part in.

    Args:
        loaded: The task, loaded with its `--set` values.
        keys: The blackboard keys the command set.
        world: The session's world (its scene and objects where they are now; read only).
        q_arm: The arm's current joint angles [rad], the IK's seed.

    Returns:
        The positions checked, by the key that set them [m].

    Raises:
        GoalRejected: Naming the first value that fails, where it is used and why.
    """
    keys = list(dict.fromkeys(keys))
    values = initial_values(loaded.machine, loaded.scenario.blackboard)
    uses = [u for u in pose_uses(loaded.machine) if u.keys() & set(keys)]
    for k in keys:
        if any(k in u.keys() for u in uses) and not is_finite(values.get(k)):
            raise GoalRejected(f"{k} = {values.get(k)!r}: not finite")
    box = workspace_box(loaded.scenario)
    checked: dict[str, list[np.ndarray]] = {}
    goals: dict[tuple[tuple[float, ...], str | None], tuple[str, np.ndarray, str | None]] = {}
    for use in uses:
        key = next(k for k in keys if k in use.keys())
        head = f"{key} = {_show(values.get(key))}"
        if use.role == HINT:
            point = _point(_resolve(use.target, values))
            if point is None:
                continue  # no hint given (null): the search takes what it finds
            _check_box(f"{head}: the position hint of {use.where}", point, box)
            _check_near(head, use, point, values, world)
            checked.setdefault(key, []).append(point)
            continue
        offset = _point(_resolve(use.offset, values)) if use.offset is not None else np.zeros(3)
        if offset is None:
            continue  # not a vector: the loader reports its type
        for base, what, on in _bases(use.target, values, world):
            p = base + offset
            where = _where(head, use, what, what != _show(base), p)
            goals.setdefault((tuple(round(float(v), 9) for v in p), on), (where, p, on))
            checked.setdefault(key, []).append(p)
    # every position against the box and the zones first: the IK only for what passed them
    for where, p, on in goals.values():
        _check_box(where, p, box)
        _check_clear(where, p, world, on)
    for where, p, _ in goals.values():
        _check_reach(where, p, world, q_arm)
    return checked


def _show(value: Any) -> str:
    point = _point(value)
    if point is None:
        return repr(value)
    # Python's round, not numpy's: that scales by 1e4 first and overflows near 1e308
    return str([round(float(v), 4) for v in point])


def _where(head: str, use: PoseUse, what: str, named: bool, p: np.ndarray) -> str:
    """`place_at = pad: TRANSPORT: $place_at (pad at [...]) + $hover = [...]`: which value, the
    state and parameter that use it, and how the position is made (when it is not the value)."""
    at = f"{head}: {use.where.removesuffix('.target')}"
    if use.offset is None and not named:
        return at
    if parse_ref(use.target) is not None:
        target = f"{use.target} ({what})" if named else use.target
    else:  # a name or a position, written in the machine
        target = what
    if use.offset is not None:
        offset = use.offset if isinstance(use.offset, str) else _show(use.offset)
        target = f"{target} + {offset}"
    return f"{at}: {target} = {_show(p)}"


def _resolve(value: Any, values: dict[str, Any]) -> Any:
    """`$key`, `$key.field`, `$key[i]` -> the value at the start of the task (None: unknown)."""
    ref = parse_ref(value)
    if ref is None:
        return value
    out: Any = values.get(ref[0])
    for part in ref[1]:
        if isinstance(out, dict) and part in out:
            out = out[part]
        elif isinstance(out, list) and isinstance(part, int) and -len(out) <= part < len(out):
            out = out[part]
        else:
            return None
    return out


def _point(value: Any) -> np.ndarray | None:
    """[x, y, z], or a pose mapping's `pos` -> a float array; None if not a position."""
    if isinstance(value, dict) and "pos" in value:
        value = value["pos"]
    if isinstance(value, np.ndarray):
        value = value.tolist()
    if (
        isinstance(value, (list, tuple))
        and len(value) == 3
        and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value)
    ):
        return np.asarray(value, float)
    return None


def _bases(target: Any, values: dict[str, Any], world: World) -> list[_Base]:
    """Where `target` stands for: a position, an object or marker where it is now, or — for a
    pose only known once the machine runs (a search writes it) — every object it could be."""
    value = _resolve(target, values)
    point = _point(value)
    if point is not None:
        return [(point, _show(point), None)]
    if isinstance(value, str):
        if value in world.objects:
            return [(_object_pos(world, value), f"{value} at {_object_at(world, value)}", value)]
        if value in world.markers:
            pos = world.markers[value].astype(float)
            return [(pos, f"{value} at {_show(pos)}", None)]
        return []  # not a name of this scene: the loader reports it
    if value is None:
        return [(_object_pos(world, n), f"{n} at {_object_at(world, n)}", n) for n in world.objects]
    return []


def _object_pos(world: World, name: str) -> np.ndarray:
    return np.asarray(world.data.xpos[world.objects[name].body_id], float).copy()


def _object_at(world: World, name: str) -> str:
    return _show(_object_pos(world, name))


def _check_box(where: str, p: np.ndarray, box: tuple[np.ndarray, np.ndarray] | None) -> None:
    if box is None:
        return
    lo, hi = box
    if np.any(p < lo) or np.any(p > hi):
        raise GoalRejected(f"{where}: outside the workspace [{lo.tolist()} .. {hi.tolist()}] m")


def _check_near(
    head: str, use: PoseUse, p: np.ndarray, values: dict[str, Any], world: World
) -> None:
    """A position hint must have something near it: the object looked for (or any object, if
    the search names none it can tell now) within the hint's radius, in the horizontal plane."""
    radius = _resolve(use.radius, values)
    if not isinstance(radius, (int, float)) or isinstance(radius, bool):
        return  # not a number: the loader reports it
    wanted = _resolve(use.object, values)
    names = [wanted] if isinstance(wanted, str) and wanted in world.objects else list(world.objects)
    if not names:
        raise GoalRejected(f"{head}: the position hint of {use.where}: the scene has no objects")
    dist = {n: float(np.linalg.norm(_object_pos(world, n)[:2] - p[:2])) for n in names}
    nearest = min(dist, key=dist.__getitem__)
    if dist[nearest] > radius:
        raise GoalRejected(
            f"{head}: the position hint of {use.where}: nothing within {radius * 1000:.0f} mm "
            f"of it (the nearest, {nearest} at {_object_at(world, nearest)}, is "
            f"{dist[nearest] * 1000:.0f} mm away in the horizontal plane)"
        )


def _check_clear(where: str, p: np.ndarray, world: World, on: str | None) -> None:
    table = world.scenario.scene.table
    cx, cy = table.center_xy
    sx, sy = table.size_xy
    if abs(p[0] - cx) <= sx / 2 and abs(p[1] - cy) <= sy / 2 and p[2] < table.height:
        raise GoalRejected(f"{where}: inside the table (its top is at z = {table.height} m)")
    data = world.data
    for name, h in world.objects.items():
        if name == on:
            continue  # the object the target is taken from: the hand goes to grasp it
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
