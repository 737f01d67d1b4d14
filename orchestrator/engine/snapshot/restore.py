"""A run snapshot put back on a run built the normal way: resume from data, not by replay.

The run is built for the header's recipe and seed as any run is (runner.new_run), then the
recorded state is put into it (state.py says what is recorded):

* the model's arrays a run may reshape (recorded whole) and the digests of the others;
* MuJoCo's integration state by `mj_setState` and its trees' sleep counters (which
  `mj_getState` does not hold), then `mj_forward` for the derived quantities;
* the machine's active path entered again without its entry actions, each running skill
  made from its recorded parameters and given its state by `restore_state(data)`
  (machine_state.py); each success check's state by its `restore_state(data)`;
* the plain data of every other object of the run by its path (graph.py: the controller,
  the IK, the context, the blackboard, the metrics, the task log, the guards, the stops);
* every numpy Generator's bit-generator state, by path.

What the file holds selects objects the rebuilt run already has and fills their data: it
never names a class to build nor a function to call. A recorded object the rebuilt run has
no counterpart for is an error naming it (the resume would not be the run it was).
"""

from __future__ import annotations

import hashlib
from typing import Any

import mujoco
import numpy as np

from ..runner import RunState, new_run
from .data import objects
from .errors import SnapshotError
from .graph import apply_graph
from .machine_state import restore_machine, settle_machine
from .state import ROWS, declared, model_digest, own_state

__all__ = ["restore_run"]

_INTEGRATION = mujoco.mjtState.mjSTATE_INTEGRATION


def _put_model(model: mujoco.MjModel, recorded: dict[str, Any], arrays: dict[str, Any]) -> None:
    for name in recorded["model_small"]:
        now, value = getattr(model, str(name), None), arrays.get(f"model/{name}")
        if not isinstance(now, np.ndarray) or not isinstance(value, np.ndarray):
            raise ValueError(f"the model has no array {str(name)[:40]!r}")
        if value.shape != now.shape or value.dtype != now.dtype:
            raise ValueError(f"the model's {name} is of another shape")
        np.copyto(now, value)
    for name, digest in recorded["model_large"].items():
        now = getattr(model, name, None)
        if not isinstance(now, np.ndarray):
            raise ValueError(f"the model has no array {name[:40]!r}")
        if hashlib.sha256(np.ascontiguousarray(now).tobytes()).hexdigest() != digest:
            raise ValueError(f"the model's {name} is not the recorded one")
    if model_digest(model) != recorded["model_sha256"]:
        raise ValueError("a snapshot of another model")


def _put_mujoco(run: RunState, recorded: dict[str, Any], arrays: dict[str, Any]) -> None:
    ctx = run.ctx
    model, data = ctx.model, ctx.data
    state, asleep = recorded["mujoco"], arrays.get("tree_asleep")
    size = mujoco.mj_stateSize(model, _INTEGRATION)
    if not isinstance(state, np.ndarray) or state.shape != (size,):
        raise ValueError("MuJoCo's state is not of this model's size")
    if not isinstance(asleep, np.ndarray) or asleep.shape != data.tree_asleep.shape:
        raise ValueError("MuJoCo's sleep counters are not of this model's size")
    mujoco.mj_setState(model, data, state, _INTEGRATION)
    np.copyto(data.tree_asleep, asleep)
    # the derived quantities (site poses, contacts, sensors) computed from the state: the
    # last physics step left those of the state before it (see docs/time-travel.md)
    mujoco.mj_forward(model, data)
    for w, (number, lastinfo) in zip(data.warning, recorded["warnings"], strict=True):
        w.number, w.lastinfo = int(number), int(lastinfo)


def restore_run(
    loaded: Any, seed: int, recorded: dict[str, Any], arrays: dict[str, np.ndarray], where: str
) -> RunState:
    """The run of `loaded` for `seed`, holding the state `recorded` (state.capture, decoded).

    Raises:
        SnapshotError: The recorded state does not fit this run (named).
    """
    run = new_run(loaded, seed)
    try:
        run.started = bool(recorded["started"])
        if run.started:
            restore_machine(run, recorded["machine"])
        graph = recorded["graph"]
        apply_graph(run, graph, own_state, ROWS)
        if run.started:
            settle_machine(run)  # the active guards, activated; their state comes next
        left = apply_graph(run, graph, own_state, ROWS)
        if left:
            raise ValueError(f"no place in the rebuilt run for {', '.join(left[:4])}")
        rngs = recorded["generators"]
        for path, obj in objects(run.episode):
            if isinstance(obj, np.random.Generator) and path in rngs:
                obj.bit_generator.state = rngs[path]
        states = dict(recorded["declared"])
        for path, obj in declared(run):
            if path in states:
                obj.restore_state(states.pop(path))
        if states:
            raise ValueError(f"no place in the rebuilt run for {', '.join(sorted(states)[:4])}")
        run.ctx.blackboard._values = dict(recorded["blackboard"])
        _put_model(run.ctx.model, recorded, arrays)
        _put_mujoco(run, recorded, arrays)
    except SnapshotError:
        raise
    except (ValueError, KeyError, TypeError, AttributeError) as exc:
        raise SnapshotError(f"{where}: the snapshot does not fit the rebuilt run: {exc}") from None
    return run
