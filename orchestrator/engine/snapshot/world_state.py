"""The state of a world between two control ticks, as data, and how it is put back on a world
built the normal way (a live session's snapshot: live/snapshots.py).

Recorded: MuJoCo's integration state and the model's digest, every numpy Generator reachable
from the context (by path), and the plain-data attributes of the context, the controller,
the IK, the world, its step clock and the encoders. Put back on a world built from the same
scenario and seed: the MuJoCo state by `mj_setState` (then `mj_forward`), each generator's
state, and each attribute — an array into the array already there (`np.copyto`: views into it
stay views), anything else set. An array
that is a view of other memory (into MjData) is not written: MuJoCo's state brings it back.
"""

from __future__ import annotations

from typing import Any

import mujoco
import numpy as np
from pydantic import BaseModel

from ...skills.plain_state import attributes, holds_view
from ..context import Context
from .data import decode, encode, objects, plain_state
from .errors import SnapshotError
from .state import BRAKE_FIELDS, model_digest, mujoco_state

__all__ = ["apply_world", "capture_world"]

_INTEGRATION = mujoco.mjtState.mjSTATE_INTEGRATION


def _parts(ctx: Context) -> dict[str, Any]:
    """The objects whose plain data is recorded, by name."""
    cell = ctx.cell  # what lives as long as the world (engine/cell.py)
    return {"ctx": ctx, "cell": cell, "hand": cell.hand, "wrist": cell.wrist,
            "controller": cell.controller, "ik": cell.ik, "world": cell.world,
            "clock": cell.world.step_clock, "encoders": cell.encoders}  # fmt: skip


def capture_world(ctx: Context) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """The world of `ctx` as (JSON tree, arrays)."""
    tree: dict[str, Any] = {"model_sha256": model_digest(ctx.model), "mujoco": {"$array": "mj"}}
    arrays = {"mj": mujoco_state(ctx.model, ctx.data)}
    for field in BRAKE_FIELDS:  # the holding brakes engaged now (an e-stop's hold)
        arrays[f"brake/{field}"] = np.array(getattr(ctx.model, field))
    tree["braked"] = sorted(int(j) for j in ctx.world.braked)
    rngs = {p: o.bit_generator.state for p, o in objects(ctx) if isinstance(o, np.random.Generator)}
    tree["generators"], _ = encode(rngs, "g/")
    for name, obj in _parts(ctx).items():
        tree[name], more = encode(plain_state(obj), f"{name}/")
        arrays.update(more)
    return tree, arrays


def apply_world(tree: Any, arrays: dict[str, np.ndarray], ctx: Context, where: str) -> None:
    """Put the world `capture_world` recorded back on `ctx` (a world built for the same
    scenario and seed).

    Raises:
        SnapshotError: The data does not fit this world (another model, a missing part).
    """
    try:
        state = decode(tree, arrays)
        if not isinstance(state, dict) or state.get("model_sha256") != model_digest(ctx.model):
            raise ValueError("a snapshot of another model")
        mj = state["mujoco"]
        size = mujoco.mj_stateSize(ctx.model, _INTEGRATION)
        if not isinstance(mj, np.ndarray) or mj.dtype != np.float64 or mj.shape != (size,):
            raise ValueError("MuJoCo's state is not of this model's size")
        for field in BRAKE_FIELDS:
            now, value = getattr(ctx.model, field), arrays.get(f"brake/{field}")
            if value is None or value.shape != now.shape or value.dtype != now.dtype:
                raise ValueError(f"no holding-brake state {field} of this model's shape")
            now[...] = value
        braked = state.get("braked", [])
        if not isinstance(braked, list) or not all(isinstance(j, int) for j in braked):
            raise ValueError("the braked joints are not a list of joint indices")
        ctx.world.braked = set(braked)  # `release_brakes` releases what is engaged
        mujoco.mj_setState(ctx.model, ctx.data, mj, _INTEGRATION)
        mujoco.mj_forward(ctx.model, ctx.data)
        rngs = state["generators"]
        for path, obj in objects(ctx):
            if isinstance(obj, np.random.Generator) and path in rngs:
                obj.bit_generator.state = rngs[path]
        for name, obj in _parts(ctx).items():
            _apply(obj, state[name], f"{where}: {name}")
    except SnapshotError:
        raise
    except (ValueError, KeyError, TypeError, AttributeError) as exc:
        raise SnapshotError(f"{where}: the snapshot does not fit this world: {exc}") from None


def _apply(obj: Any, values: Any, where: str) -> None:
    if not isinstance(values, dict):
        raise ValueError(f"{where} is not a mapping")
    own = attributes(obj)
    for key, value in values.items():
        if key not in own:
            raise ValueError(f"{where} has no attribute {key!r}")
        now = own[key]
        if isinstance(now, BaseModel):
            continue  # configuration, built from the scenario
        if holds_view(now):
            # a view of memory MuJoCo's state brings back, or a tuple of them (the encoders'
            # exact reading): replaced by the file's copies, the encoders read the snapshot's
            # joint state forever after a restore and the arm ran open-loop (3.7 rad/s while
            # ESTOPPED and braked, tests/test_live_restore_world.py)
            continue
        if isinstance(now, np.ndarray):
            if (
                isinstance(value, np.ndarray)
                and value.shape == now.shape
                and (value.dtype == now.dtype)
            ):
                np.copyto(now, value)  # in place: whatever holds it sees the value
            else:
                setattr(obj, key, value.copy() if isinstance(value, np.ndarray) else value)
        elif isinstance(now, tuple) and isinstance(value, list):
            setattr(obj, key, tuple(value))
        else:
            setattr(obj, key, value)
