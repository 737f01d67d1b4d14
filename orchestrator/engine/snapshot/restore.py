"""A run snapshot put back on a run built the normal way: resume from data, not by replay.

The run is built for the header's recipe and seed as any run is (runner.new_run), then the
recorded state is put into it (state.py says what is recorded):

* the model's arrays a run may reshape (recorded whole) and the digests of the others;
* MuJoCo's integration state by `mj_setState`, its sleeping trees (which `mj_getState` does
  not hold), and MjData's derived quantities (site poses, contacts, sensors) as the last
  physics step left them: `mj_forward` from the state before that step (the step loop
  keeps it), then the state after it;
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
from ..step import SLEEP_ARRAYS, SLEEP_COUNTS
from .data import objects
from .errors import SnapshotError
from .graph import apply_graph, walk
from .machine_state import IncompleteState, restore_machine, settle_machine
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


def _put_sleep(data: mujoco.MjData, arrays: dict[str, Any], counts: list[Any]) -> None:
    """MuJoCo's sleeping trees (`SLEEP_ARRAYS`, `SLEEP_COUNTS`), which `mj_setState` leaves."""
    if not isinstance(counts, list) or len(counts) != len(SLEEP_COUNTS):
        raise ValueError("MuJoCo's awake counts are not of this version's")
    for name in SLEEP_ARRAYS:
        now, value = getattr(data, name), arrays.get(name)
        if not isinstance(value, np.ndarray) or value.shape != now.shape:
            raise ValueError(f"MuJoCo's {name} is not of this model's size")
        np.copyto(now, value)
    for name, value in zip(SLEEP_COUNTS, counts, strict=True):
        setattr(data, name, int(value))


def _put_mujoco(run: RunState, recorded: dict[str, Any], arrays: dict[str, Any]) -> None:
    """MuJoCo's state and MjData's derived quantities as the last physics step left them:
    `mj_forward` from the state before that step (the step loop keeps it, its sleeping
    trees too), then the state after it."""
    ctx, loop = run.ctx, run.episode.loop
    model, data = ctx.model, ctx.data
    state = recorded["mujoco"]
    size = mujoco.mj_stateSize(model, _INTEGRATION)
    if not isinstance(state, np.ndarray) or state.shape != (size,):
        raise ValueError("MuJoCo's state is not of this model's size")
    sleep = {k.removeprefix("sleep/"): v for k, v in arrays.items() if k.startswith("sleep/")}
    if ctx.tick > 0:
        mujoco.mj_setState(model, data, loop.before_last_step, _INTEGRATION)
        _put_sleep(data, loop.sleep_before_last_step, list(loop.awake_before_last_step))
    else:
        mujoco.mj_setState(model, data, state, _INTEGRATION)
        _put_sleep(data, sleep, recorded["awake_counts"])
    mujoco.mj_forward(model, data)
    mujoco.mj_setState(model, data, state, _INTEGRATION)
    _put_sleep(data, sleep, recorded["awake_counts"])
    for w, (number, lastinfo) in zip(data.warning, recorded["warnings"], strict=True):
        w.number, w.lastinfo = int(number), int(lastinfo)


LAZY_PARTS = (("_cameras", "cameras"), ("_renderer", "renderer"))
"""Parts a run makes on first use (attribute, the property that makes it): the scenario's
camera rig, its renderer. A part the recorded run had made is made again the same way."""


def _make_lazy_parts(run: RunState, graph: dict[str, Any]) -> None:
    for _ in LAZY_PARTS:  # a part made inside another (the renderer in the rig): one more pass
        for path, obj in walk(run, own_state):
            for attr, prop in LAZY_PARTS:
                if getattr(obj, attr, 0) is None and f"{path}.{attr}" in graph:
                    getattr(obj, prop)


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
        _make_lazy_parts(run, graph)
        apply_graph(run, graph, own_state, ROWS)
        if run.started:
            settle_machine(run)  # the active guards, activated; their state comes next
        left = apply_graph(run, graph, own_state, ROWS)
        if left:
            raise IncompleteState(f"no place in the rebuilt run for {', '.join(left[:4])}")
        rngs = recorded["generators"]
        for path, obj in objects(run.episode):
            if isinstance(obj, np.random.Generator) and path in rngs:
                obj.bit_generator.state = rngs[path]
        states = dict(recorded["declared"])
        for path, obj in declared(run):
            if path in states:
                obj.restore_state(states.pop(path))
        if states:
            raise IncompleteState(
                f"no place in the rebuilt run for {', '.join(sorted(states)[:4])}"
            )
        run.ctx.blackboard._values = dict(recorded["blackboard"])
        _put_model(run.ctx.model, recorded, arrays)
        _put_mujoco(run, recorded, arrays)
    except SnapshotError:
        raise
    except (ValueError, KeyError, TypeError, AttributeError) as exc:
        raise SnapshotError(f"{where}: the snapshot does not fit the rebuilt run: {exc}") from None
    return run
