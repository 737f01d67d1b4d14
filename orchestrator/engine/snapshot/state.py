"""The state a run snapshot records, as plain data (data.py), and the check that a rebuilt run
holds it.

Recorded between two control ticks:

* MuJoCo's own state: `mj_getState(..., mjSTATE_INTEGRATION)` (time, positions, velocities,
  actuator state, warm start, controls, applied forces, mocap, equality flags) and the SHA-256
  of every array of the model (a conveyor reshapes parcels, a tissue probe moves bodies);
* the state of every numpy Generator the run reaches (noise of the encoders, the wrist sensor,
  perception, faults), as its bit generator's state;
* the controller and the IK: their plain-data attributes (setpoints, gains, filters, the
  joint limiter, the QP's cached rows);
* the machine's active path, and each running skill's and each success check's
  `snapshot_state()` (skills/base.py, success/base.py), by where it is in the run;
* the blackboard, the metrics and the task log.

None of it is an object: reading it back builds numbers, strings, lists, dicts and arrays.
"""

from __future__ import annotations

import hashlib
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import mujoco
import numpy as np

from ...skills import Skill
from ...success.base import SuccessCheck
from ..context import Context, Event
from ..episode import Episode
from ..runner import RunState
from ..step import SLEEP_ARRAYS, SLEEP_COUNTS
from ..tasks import TaskEntry
from .data import encode, objects, plain_state
from .graph import capture_graph, walk
from .machine_state import capture_machine

__all__ = [
    "ROWS",
    "capture",
    "declared",
    "detached",
    "model_arrays",
    "model_digest",
    "mujoco_state",
    "own_state",
]

ROWS: tuple[type, ...] = (Event, TaskEntry)
"""The record types a run keeps lists of (its log, its task log): recorded field by field."""

_SMALL = 1 << 20
"""Model arrays up to this size [bytes] are recorded whole (a run may reshape them: a
conveyor's parcels, the holding brakes, a friction fault); larger ones by their digest."""


def own_state(obj: Any) -> bool:
    """An object that declares its state (`snapshot_state()` and `restore_state(data)`: a
    skill, a success check, the IK, the wrist sensor's noise): that is what is recorded."""
    return (
        not isinstance(obj, type)
        and callable(getattr(obj, "snapshot_state", None))
        and callable(getattr(obj, "restore_state", None))
    )


def declared(run: RunState) -> Iterator[tuple[str, Any]]:
    """The objects of `run` but its running skills that declare their state, by path (the
    skills are the machine's: machine_state.py)."""
    for path, obj in walk(run, own_state):
        if own_state(obj) and not isinstance(obj, Skill):
            yield path, obj


def _numeric_arrays(model: mujoco.MjModel) -> Iterator[tuple[str, np.ndarray]]:
    """Every numeric array of `model`, by name in name order."""
    for name in sorted(dir(model)):
        if name.startswith("_"):
            continue
        try:
            value = getattr(model, name)
        except Exception:  # noqa: S112 (a property that does not apply to this model)
            continue
        if isinstance(value, np.ndarray) and not value.dtype.hasobject:
            yield name, value


def model_arrays(model: mujoco.MjModel) -> tuple[dict[str, np.ndarray], dict[str, str]]:
    """The model's arrays up to `_SMALL` bytes by name, and the digests of the larger ones."""
    small: dict[str, np.ndarray] = {}
    large: dict[str, str] = {}
    for name, value in _numeric_arrays(model):
        if value.nbytes <= _SMALL:
            small[name] = np.array(value, copy=True)
        else:
            large[name] = hashlib.sha256(np.ascontiguousarray(value).tobytes()).hexdigest()
    return small, large


_INTEGRATION = mujoco.mjtState.mjSTATE_INTEGRATION


@contextmanager
def detached(ctx: Context, episode: Episode | None) -> Iterator[None]:
    """Within: `episode`'s observers, their listeners on `ctx` and the executor's
    `entry_listeners` are taken off (they are this process's, not the run's); put back after."""
    observers = episode.observers if episode is not None else []
    own = {id(o) for o in observers}
    listeners = ctx.listeners
    entry = episode.executor.entry_listeners if episode is not None else []
    try:
        if episode is not None:
            episode.observers = []
            episode.loop.set_observers([])
            episode.executor.entry_listeners = []
        ctx.listeners = [f for f in listeners if id(getattr(f, "__self__", None)) not in own]
        yield
    finally:
        ctx.listeners = listeners
        if episode is not None:
            episode.observers = observers
            episode.loop.set_observers(observers)
            episode.executor.entry_listeners = entry


def mujoco_state(model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray:
    """MuJoCo's integration state of `data` (mj_getState)."""
    out = np.empty(mujoco.mj_stateSize(model, _INTEGRATION))
    mujoco.mj_getState(model, data, out, _INTEGRATION)
    return out


BRAKE_FIELDS = ("dof_frictionloss", "dof_solimp", "dof_solref")
"""Model arrays a run changes as it goes: the holding brakes (world/world.py `engage_brake`)
are MuJoCo's friction loss made rigid. They are the world's state, recorded and put back
with it (world_state.py), not part of the model's identity."""


def model_digest(model: mujoco.MjModel) -> str:
    """SHA-256 of every array of `model` (by name, in name order) but `BRAKE_FIELDS`."""
    h = hashlib.sha256()
    for name, value in _numeric_arrays(model):
        if name not in BRAKE_FIELDS:
            h.update(name.encode() + b"\0")
            h.update(np.ascontiguousarray(value).tobytes())
    return h.hexdigest()


def _who(obj: Any) -> str:
    cls = type(obj)
    return f"{cls.__module__}.{cls.__qualname__}"


def capture(run: RunState) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """`run`'s state as (JSON tree, arrays): see the module docstring. The run is left as it
    was."""
    ctx = run.ctx
    tree: dict[str, Any] = {
        "t": ctx.t,
        "tick": ctx.tick,
        "started": run.started,
        "leaf": run.executor.leaf if run.started else None,
        "model_sha256": model_digest(ctx.model),
        "mujoco": {"$array": "mujoco"},
    }
    arrays: dict[str, np.ndarray] = {"mujoco": mujoco_state(ctx.model, ctx.data)}
    rngs: dict[str, Any] = {}
    skills: dict[str, Any] = {}
    checks: dict[str, Any] = {}
    with detached(ctx, run.episode):
        for path, obj in objects(run.episode):
            if isinstance(obj, np.random.Generator):
                rngs[path] = obj.bit_generator.state
            elif isinstance(obj, Skill):
                skills[path] = {"skill": _who(obj), "state": obj.snapshot_state()}
            elif isinstance(obj, SuccessCheck):
                checks[path] = {"check": _who(obj), "state": obj.snapshot_state()}
    parts = {
        "generators": rngs,
        "skills": skills,
        "checks": checks,
        "controller": plain_state(ctx.controller),
        "ik": plain_state(ctx.ik),
        "blackboard": dict(ctx.blackboard._values),
        "metrics": ctx.metrics,
        "tasks": plain_state(ctx.tasks),
    }
    with detached(ctx, run.episode):
        parts["graph"] = capture_graph(run, own_state, ROWS)
        parts["declared"] = {path: obj.snapshot_state() for path, obj in declared(run)}
        parts["checks"] = checks
        if run.started:
            parts["machine"] = capture_machine(run)
    small, large = model_arrays(ctx.model)
    parts["model_large"] = large
    for name, value in small.items():
        arrays[f"model/{name}"] = value
    tree["model_small"] = sorted(small)
    tree["warnings"] = [[int(w.number), int(w.lastinfo)] for w in ctx.data.warning]
    for name in SLEEP_ARRAYS:  # MuJoCo's sleeping trees: not in mj_getState
        arrays[f"sleep/{name}"] = np.array(getattr(ctx.data, name), copy=True)
    tree["awake_counts"] = [int(getattr(ctx.data, name)) for name in SLEEP_COUNTS]
    for name, value in parts.items():
        tree[name], more = encode(value, f"{name}/")
        arrays.update(more)
    return tree, arrays
