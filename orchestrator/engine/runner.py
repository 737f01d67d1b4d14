"""The runner: one episode on simulated time — control ticks, physics steps, guards."""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from typing import Any, Protocol

import mujoco
import numpy as np

from ..exceptions import OrchestratorError
from ..guards import get_guard
from ..guards.base import Guard
from ..language.load import LoadedScenario
from ..language.loading import MachineNode, initial_values
from ..language.machine import SAFE_STOP, guard_entries
from ..robots import Controller
from ..skills.ik import IKSolver
from ..world.realism import link_mass_scale
from ..world.world import World, as_index, robot_only_model
from .blackboard import Blackboard
from .context import Context
from .executor import Executor, Stopper
from .faults import FaultInjector
from .result import RunResult
from .safety_stop import SafetyStop
from .success import errors, evaluate
from .tasks import metrics as task_metrics
from .trace_truth import TraceTruth

__all__ = ["WALL_GRACE_S", "Observer", "WallTimeExceeded", "make_context", "run_episode"]

WALL_GRACE_S = 5.0
"""Wall time the controlled stop may take after the wall limit before the run is cut [s]."""


class WallTimeExceeded(OrchestratorError):
    """The episode ran longer than its wall-clock limit; it was stopped (arm brought to rest).

    Attributes:
        result: What the episode had done when it was stopped (outcome `failed`, the reason in
            `metrics["error"]`).
    """

    def __init__(self, message: str, result: RunResult) -> None:
        super().__init__(message)
        self.result = result


SETTLE_S = 0.2
"""Simulated time kept running after the machine finishes, before success is judged [s]."""
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


class Observer(Protocol):
    """Watches a run (the Rerun recorder is one). Called on simulated time only.

    An observer may also define `on_step(ctx)`: it is then called after every physics step
    (bench/physical_honesty.py instruments the plant that way). Observers without it cost the
    physics step nothing.
    """

    def on_start(self, ctx: Context, executor: Executor) -> None: ...
    def on_tick(self, ctx: Context, executor: Executor) -> None: ...
    def on_end(self, ctx: Context, executor: Executor, result: RunResult) -> None: ...


def initial_blackboard(machine: MachineNode, overrides: dict[str, Any]) -> Blackboard:
    """Defaults declared in the machine tree (outer levels win), then the scenario's values."""
    return Blackboard(initial_values(machine, overrides))


def make_guards(refs, ctx: Context) -> list[Guard]:
    out = []
    for _, name, params in guard_entries(refs):
        cls = get_guard(name)
        guard = cls(cls.Params.model_validate(params))
        guard.bind(ctx)
        out.append(guard)
    return out


def make_context(
    world: World, controller: Controller, blackboard: Blackboard, seed: int, dt_control: float
) -> Context:
    """The context of an episode (or of a live session): sensors, IK, the blackboard."""
    ctx = Context(world, controller, blackboard, np.random.default_rng([seed, 1]), dt_control)
    ctx.ik = IKSolver(
        world.robot, robot_only_model(world.robot), dt_control, world.scenario.robot.base_pos
    )
    return ctx


def run_episode(
    loaded: LoadedScenario,
    seed: int,
    observers: Sequence[Observer] | None = None,
    max_wall_s: float | None = None,
) -> RunResult:
    """Run one episode of `loaded` with `seed`: same inputs, same result, bit for bit.

    Args:
        loaded: The validated scenario.
        seed: Episode seed.
        observers: Told about the run on simulated time (the Rerun recorder).
        max_wall_s: Wall-clock limit [s] (None: none). Past it the machine is halted and the
            arm brought to rest, as at the time limit, then `WallTimeExceeded` is raised.

    Raises:
        WallTimeExceeded: The episode ran past `max_wall_s`.
    """
    observers = observers or []
    wall0 = time.perf_counter()
    scn = loaded.scenario
    world = World.build(scn, seed)
    model, data = world.model, world.data
    controller = Controller(
        world.robot,
        float(world.model.opt.timestep),
        link_mass_scale(scn.physics.realism, world.robot.pinocchio_model().njoints - 1, seed),
    )
    controller.hold(world.home)
    dt = float(model.opt.timestep)
    n_sub = max(1, round(1.0 / (scn.physics.control_hz * dt)))
    dt_control = n_sub * dt
    ctx = make_context(
        world,
        controller,
        initial_blackboard(loaded.machine, world.scenario.blackboard),
        seed,
        dt_control,
    )
    safe_stop = scn.physics.safe_stop
    executor = Executor(
        loaded.machine,
        ctx,
        make_guards(scn.guards, ctx),
        lambda: SafetyStop(ctx, safe_stop),
        safe_stop.hold_s,
        make_guards(["joint_limits"], ctx),
        make_guards([{"contact_force": {"max_n": safe_stop.force_ceiling_n}}], ctx),
    )
    injector = FaultInjector(list(scn.faults), ctx, executor, list(scn.events))

    act_idx = as_index(world.arm_act)
    # The physics step runs 500 times per simulated second: MjData's arrays are bound once
    # (they are views that never move), so the loop does no attribute lookups through MjData.
    qpos, ctrl = data.qpos, data.ctrl
    warnings = data.warning.number
    diverged_warnings = (
        warnings[_DIVERGED_INDEX].tolist  # a view, bound once
        if isinstance(_DIVERGED_INDEX, slice)
        else lambda: warnings[_DIVERGED_INDEX].tolist()  # noqa: PLW0108 (a copy: re-read)
    )
    compute, mj_step, read_encoders = controller.compute, mujoco.mj_step, ctx.encoders.read
    time_limit = scn.physics.time_limit_s
    inf = math.inf
    observer_steps = [obs.on_step for obs in observers if hasattr(obs, "on_step")]
    trace_truth = TraceTruth(ctx)
    if world.conveyor is not None:  # the belt's drive, light barrier and feed
        observer_steps.append(world.conveyor.on_step)
    with_trace = [*observer_steps, trace_truth.on_step]
    true_force_sq = ctx.true_wrist_force_norm_sq
    max_force_sq = 0.0
    timed_out = False
    diverged: str | None = None
    end_stop: Stopper | None = None  # the controlled stop that ends the run
    settle_until = math.inf
    wall_cut: str | None = None  # why the wall-clock limit ended the run
    wall_deadline = wall0 + max_wall_s if max_wall_s is not None else math.inf
    for obs in observers:
        obs.on_start(ctx, executor)
    executor.start()
    injector.fire_due(ctx.t)  # faults at t = 0
    while True:
        if not executor.done:
            executor.tick()
        for obs in observers:
            obs.on_tick(ctx, executor)
        if executor.done:
            abort_stop = executor.stop
            if end_stop is None:
                if (
                    executor.outcome == "aborted"
                    and executor.final_state == SAFE_STOP
                    and (abort_stop is not None and not abort_stop.active)
                ):
                    break  # the safe stop brought the arm to rest and held it
                if abort_stop is not None and abort_stop.active:
                    end_stop = abort_stop  # the time limit fell inside the stop: finish it
                else:
                    end_stop = SafetyStop(ctx, safe_stop)
                    end_stop.start("end of run", gentle=executor.violation is None)
                settle_until = ctx.t + (0.0 if executor.violation else SETTLE_S)
            assert end_stop is not None
            if (end_stop.at_rest and ctx.t >= settle_until - 1e-9) or end_stop.timed_out():
                break
        stop = end_stop if end_stop is not None else executor.stop
        if stop is not None and not stop.active:
            stop = None
        # states change in tick() or abort(), never between: bind the checks once per tick
        checks = executor.active_checks
        # faults only schedule in tick(), fire_due() and abort(): read the due time there, and
        # MjData's time (an attribute lookup through the bindings) only when one is due
        due = injector.next_t
        # a trace (a contact skill) starts and ends in tick(): its ground-truth probe runs on
        # the steps of the ticks it is running, nothing is called on the others
        steppers = observer_steps if ctx.trace is None else with_trace
        fault = ctx.actuator_fault  # set by a fault: only in fire_due()
        ctx.advance_gripper(executor.rate)
        for _ in range(n_sub):
            tau = compute(*read_encoders())
            if fault is not None:
                tau = fault.apply(tau)
            ctrl[act_idx] = tau
            mj_step(model, data)
            # the reported peak is the true force of every step, not a per-tick sample
            force_sq = true_force_sq()
            if force_sq > max_force_sq:  # noqa: PLR1730 (cheaper than max() per step)
                max_force_sq = force_sq
            for on_step in steppers:
                on_step(ctx)
            if due != inf and data.time >= due - 1e-9:
                injector.fire_due(data.time)
                fault = ctx.actuator_fault
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
                    executor.abort(violation)
                    checks = executor.active_checks  # none while the safety response runs
                    stop = executor.stop
                    due = injector.next_t
                    break
        ctx.tick += 1
        # a NaN or an inf anywhere makes the sum non-finite: the element-wise test only then
        # (a sum of Python floats: a numpy reduction costs more in call overhead on ~20 values)
        finite = math.isfinite(sum(qpos.tolist())) or bool(np.isfinite(qpos).all())
        if not finite or any(diverged_warnings()):
            diverged = f"physics diverged at t={ctx.t:.3f} s (state {executor.leaf})"
            break
        if ctx.t >= time_limit and not executor.done:
            timed_out = executor.violation is None
            executor.halt()
        if time.perf_counter() > wall_deadline:  # one clock read per control tick
            if wall_cut is None:
                wall_cut = (
                    f"the episode ran past its wall-clock limit of {max_wall_s:g} s at "
                    f"simulated t={ctx.t:.3f} s (state {executor.leaf}); the arm was stopped"
                )
                executor.halt()
                wall_deadline += WALL_GRACE_S  # for the controlled stop
            else:
                break

    outcome = executor.outcome or "failed"
    final_state = executor.final_state
    ctx.metrics.update(trace_truth.figures())  # before the success checks that read them
    tasks = ctx.tasks.finalize(ctx) if world.parcel_classes and not diverged else None
    judged = (
        evaluate(ctx, scn.success)
        if not diverged
        else dict.fromkeys(scn.success, (False, "physics diverged"))
    )
    success = {name: ok for name, (ok, _) in judged.items()}
    if outcome == "succeeded" and not all(success.values()):
        outcome = "failed"
    metrics: dict[str, Any] = {
        "cycle_time": round(executor.final_t, 6)
        if executor.final_t is not None and not timed_out
        else None,
        "max_wrist_force_n": round(math.sqrt(max_force_sq), 4),
        "control_ticks": ctx.tick,
    }
    metrics.update(ctx.metrics)
    if tasks is not None:
        metrics.update(task_metrics(tasks, executor.final_t or ctx.t))
        if ctx.tasks.ghost_tasks:  # detections the scheduler served that were no parcel
            metrics["tasks_without_parcel"] = ctx.tasks.ghost_tasks
    if not diverged:
        metrics.update(errors(ctx, scn.success))
    abort_stop = executor.stop
    if executor.violation is not None and abort_stop is not None:
        metrics["abort_t"] = round(executor.violation_t or 0.0, 6)
        if abort_stop.stop_time_s is not None:
            metrics["stop_time_s"] = round(abort_stop.stop_time_s, 4)
        metrics["stop_distance_mm"] = round(abort_stop.distance_m * 1000.0, 3)
    if injector.injected:
        metrics["faults"] = injector.injected
    if executor.events:
        metrics["events"] = executor.events
        metrics["paused_s"] = round(ctx.clock_offset, 6)
    if executor.pause.pauses:
        metrics["pauses"] = executor.pause.pauses
    metrics["rest_speed_rad_s"] = round(float(np.max(np.abs(data.qvel[world.arm_dof]))), 5)
    if timed_out:
        metrics["time_limit_reached"] = True
        if executor.halt_detail:
            metrics["time_limit_detail"] = f"{final_state}: {executor.halt_detail}"
    if diverged:
        metrics["error"] = diverged
    if wall_cut:
        metrics["error"] = wall_cut
    wall = time.perf_counter() - wall0
    result = RunResult(
        scenario=scn.name,
        seed=seed,
        outcome=outcome,  # type: ignore[arg-type]
        final_state=final_state,
        reason=executor.violation.to_dict() if executor.violation else None,
        sim_time=round(ctx.t, 6),
        wall_time=round(wall, 4),
        transitions=executor.transitions,
        metrics=metrics,
        success=success,
        retries=executor.retries,
        success_detail={name: text for name, (_, text) in judged.items()},
        tasks=None if tasks is None else [e.to_dict() for e in tasks],
    )
    for obs in observers:
        obs.on_end(ctx, executor, result)
    ctx.close()
    if wall_cut:
        raise WallTimeExceeded(wall_cut, result)
    return result
