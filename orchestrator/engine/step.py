"""The physics of one control tick: the one place the world is stepped.

`orchestrator run`, batch workers and a live session all step the world through `StepLoop`:
a per-step feature (a conveyor belt, a fault, the ground-truth probe of a trace, a recorder's
per-step reading, the peak wrist force) is added here once and no caller can forget it.

One control tick is `n_sub` physics steps. Each step: the controller turns the encoders'
reading into joint torques (through an injected actuator fault, if any), `mj_step` and the
world's `StepClock` advanced with it (the simulated time every reading keys on), the true
wrist force's peak, the per-step observers (the conveyor, a recorder, a trace's probe), faults
that fall due, the controlled stop (if one runs), then the active guards — a violation aborts
the machine from whatever state is active and its controlled stop starts on the next step.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from functools import partial
from typing import TYPE_CHECKING, Protocol, runtime_checkable

import mujoco
import numpy as np

from ..world.world import as_index
from .trace_truth import TraceTruth

if TYPE_CHECKING:
    from .context import Context
    from .executor import Executor, Stopper
    from .faults import FaultInjector
    from .hardware import Hardware

__all__ = ["StepLoop", "StepObserver"]

_DIVERGED = tuple(
    int(w)
    for w in (
        mujoco.mjtWarning.mjWARN_BADQACC,  # MuJoCo resets the state itself on these three,
        mujoco.mjtWarning.mjWARN_BADQPOS,  # so a finite qpos alone does not prove health
        mujoco.mjtWarning.mjWARN_BADQVEL,
    )
)
_DIVERGED_INDEX = as_index(np.array(sorted(_DIVERGED)))
"""The same warnings as one slice of `MjData.warning.number` (an index array if not adjacent)."""
_INTEGRATION = mujoco.mjtState.mjSTATE_INTEGRATION
SLEEP_ARRAYS = (
    "tree_asleep", "tree_awake", "body_awake", "body_awake_ind", "dof_awake_ind",
    "parent_awake_ind",
)  # fmt: skip
"""MjData's arrays of MuJoCo's sleeping trees: state a physics step reads that `mj_getState`
does not hold (engine/snapshot keeps them)."""
SLEEP_COUNTS = ("nbody_awake", "nparent_awake", "ntree_awake", "nv_awake")
"""MjData's counts of what is awake (with `SLEEP_ARRAYS`)."""

OnStep = Callable[["Context"], None]


@runtime_checkable
class StepObserver(Protocol):
    """An observer that watches every physics step, not only every control tick (a recorder
    of per-step signals, the plant instrumentation of bench/physical_honesty.py): it declares
    `on_step(ctx)`, called after each `mj_step`. Observers that do not implement it cost the
    physics step nothing."""

    def on_step(self, ctx: Context) -> None: ...


def _read_list(array: np.ndarray, index: np.ndarray) -> list:
    """`array[index]` as a list (an index array makes a copy: read again at every call)."""
    return array[index].tolist()


class StepLoop:
    """Steps a world one control tick at a time, for an episode or a live session.

    The loop lives as long as the world (engine/cell.py builds it); the episode it steps for
    is bound with `bind` (a run's one, each live task's, a session's idle one).

    Args:
        cell: The world, its controller, encoders, hand and sensors.

    Attributes:
        ctx: The context of the episode the loop steps for (its guards are checked against it,
            per-step observers are handed it).
        injector: Faults and timed events of a run (None: none, as in a live session).
        max_force_sq: Largest squared true wrist force of any step since `reset_peaks` [N^2]:
            the reported peak is the true force of every step, not a per-tick sample.
        trace_truth: The ground-truth probe of a contact skill's trace (its figures go to the
            metrics of the run or task).
    """

    def __init__(self, cell: Hardware) -> None:
        self.cell = cell
        self.ctx: Context | None = None
        self.n_sub = cell.n_sub
        self.injector: FaultInjector | None = None
        self.max_force_sq = 0.0
        self.trace_truth: TraceTruth | None = None
        world = cell.world
        self._belt: list[OnStep] = [world.conveyor.on_step] if world.conveyor is not None else []
        self._observer_steps: list[OnStep] = []
        self._steppers: list[OnStep] = list(self._belt)
        self._with_trace: list[OnStep] = list(self._belt)
        # The physics step runs 500 times per simulated second: MjData's arrays are bound once
        # (they are views that never move), so the loop does no attribute lookups through MjData.
        data = world.data
        self._act_idx = as_index(world.arm_act)
        self._qpos = data.qpos
        self.before_last_step = np.zeros(mujoco.mj_stateSize(world.model, _INTEGRATION))
        """MuJoCo's integration state before the last physics step of the last tick: MjData's
        derived quantities (site poses, sensors, contacts) were computed from it, and a
        snapshot resumed from its data computes them again from it (engine/snapshot)."""
        self.sleep_before_last_step = {n: getattr(data, n).copy() for n in SLEEP_ARRAYS}
        """MuJoCo's sleep arrays then (`SLEEP_ARRAYS`)."""
        self.awake_before_last_step = [0] * len(SLEEP_COUNTS)
        """MuJoCo's awake counts then (`SLEEP_COUNTS`)."""
        self._sleep_views = [
            (self.sleep_before_last_step[n], getattr(data, n)) for n in SLEEP_ARRAYS
        ]
        warnings = data.warning.number
        self._diverged_warnings = (
            warnings[_DIVERGED_INDEX].tolist  # a view, bound once
            if isinstance(_DIVERGED_INDEX, slice)
            else partial(_read_list, warnings, _DIVERGED_INDEX)  # a copy: re-read each time
        )

    def bind(self, ctx: Context) -> None:
        """Step for the episode of `ctx` from now on, with a new peak wrist force and a new
        trace probe (a run's start, a live task's, the session's idle world after a task)."""
        self.ctx = ctx
        self.max_force_sq = 0.0
        self.trace_truth = TraceTruth(ctx)
        self._with_trace = [*self._steppers, self.trace_truth.on_step]

    def _keep_before(self) -> None:
        """Keep MuJoCo's state before this physics step (see `before_last_step`)."""
        world = self.cell.world
        data = world.data
        mujoco.mj_getState(world.model, data, self.before_last_step, _INTEGRATION)
        for kept, now in self._sleep_views:
            np.copyto(kept, now)
        self.awake_before_last_step = [getattr(data, n) for n in SLEEP_COUNTS]

    def set_observers(self, observers: Iterable[object]) -> None:
        """Observers whose `on_step(ctx)` runs after every physics step (`StepObserver`: a
        recorder, the plant instrumentation of bench/physical_honesty.py); the others cost the
        step nothing."""
        self._observer_steps = [obs.on_step for obs in observers if isinstance(obs, StepObserver)]
        # observers first, then the belt (the order the run has always had)
        self._steppers = [*self._observer_steps, *self._belt]
        truth = [self.trace_truth.on_step] if self.trace_truth is not None else []
        self._with_trace = [*self._steppers, *truth]

    def tick(self, executor: Executor | None, end_stop: Stopper | None = None) -> str | None:
        """One control tick of physics: `n_sub` steps, guards checked after every one.

        Args:
            executor: The machine running (its guards, its abort and its controlled stop);
                None for an idle live session.
            end_stop: A controlled stop that outranks the executor's (the end of a run or
                task, an idle session's e-stop); None: the executor's own, if one runs.

        Returns:
            None, or why the physics diverged (a NaN or MuJoCo's own reset warnings).
        """
        ctx, cell = self.ctx, self.cell
        assert ctx is not None, "StepLoop.bind(ctx) first"
        world = cell.world
        data, model = world.data, world.model
        ctrl, act_idx = data.ctrl, self._act_idx
        compute, read_encoders = cell.controller.compute, cell.encoders.read
        mj_step = mujoco.mj_step
        clock, dt = world.step_clock, cell.dt_physics
        true_force_sq = cell.wrist.true_norm_sq
        max_force_sq = self.max_force_sq
        injector = self.injector
        inf = math.inf
        stop = end_stop
        if stop is None and executor is not None:
            stop = executor.stop
        if stop is not None and not stop.active:
            stop = None
        # states change in tick() or abort(), never between: bind the checks once per tick
        checks = executor.active_checks if executor is not None else ()
        # faults only schedule in tick(), fire_due() and abort(): read the due time there
        due = injector.next_t if injector is not None else inf
        # a trace (a contact skill) starts and ends in tick(): its ground-truth probe runs on
        # the steps of the ticks it is running, nothing is called on the others
        steppers = self._steppers if ctx.trace is None else self._with_trace
        fault = cell.actuator_fault  # set by a fault: only in fire_due()
        cell.hand.advance(executor.rate if executor is not None else 1.0)
        last = self.n_sub - 1
        for i in range(self.n_sub):
            tau = compute(*read_encoders())
            if fault is not None:
                tau = fault.apply(tau)
            ctrl[act_idx] = tau
            if i == last:  # what MjData's derived quantities are computed from (a snapshot)
                self._keep_before()
            mj_step(model, data)
            clock.t += dt  # as mj_step advances MjData.time: the same float, bit for bit
            force_sq = true_force_sq()
            if force_sq > max_force_sq:  # noqa: PLR1730 (cheaper than max() per step)
                max_force_sq = force_sq
            for on_step in steppers:
                on_step(ctx)
            if due != inf and clock.t >= due - 1e-9:
                assert injector is not None and executor is not None
                injector.fire_due(clock.t)
                fault = cell.actuator_fault
                checks = executor.active_checks
                stop = executor.stop if end_stop is None else end_stop
                due = injector.next_t
            if stop is not None:
                stop.step()
                if not stop.active:
                    stop = None
            for check in checks:
                violation = check(ctx)
                if violation is not None:
                    assert executor is not None
                    executor.abort(violation)
                    checks = executor.active_checks  # the safety response's guards only
                    stop = executor.stop
                    if injector is not None:
                        due = injector.next_t
                    break
        # what the loop bound once still holds: only an abort and a fault falling due change
        # the guards, the actuator fault and the next fault's time, both handled above (tests:
        # tests/test_guard_step_loop.py)
        assert executor is None or checks == executor.active_checks, "guards changed mid-tick"
        assert fault is cell.actuator_fault, "an actuator fault was set outside fire_due()"
        assert injector is None or due == injector.next_t, "a fault was scheduled mid-tick"
        self.max_force_sq = max_force_sq
        cell.tick += 1
        return self.diverged(executor.leaf if executor is not None else "")

    def diverged(self, leaf: str) -> str | None:
        """Why the physics diverged after the last tick, or None."""
        # a NaN or an inf anywhere makes the sum non-finite: the element-wise test only then
        # (a sum of Python floats: a numpy reduction costs more in call overhead on ~20 values)
        qpos = self._qpos
        finite = math.isfinite(sum(qpos.tolist())) or bool(np.isfinite(qpos).all())
        if not finite or any(self._diverged_warnings()):
            return f"physics diverged at t={self.cell.world.step_clock.t:.3f} s (state {leaf})"
        return None
