"""The runner: one episode on simulated time — control ticks, physics steps, guards."""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from typing import Any, Protocol

import mujoco
import numpy as np

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
from .success import evaluate
from .trace_truth import TraceTruth

__all__ = ["Observer", "run_episode"]

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


def run_episode(
    loaded: LoadedScenario, seed: int, observers: Sequence[Observer] | None = None
) -> RunResult:
    """Run one episode of `loaded` with `seed`: same inputs, same result, bit for bit."""
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
    ctx = Context(
        world,
        controller,
        initial_blackboard(loaded.machine, scn.blackboard),
        np.random.default_rng([seed, 1]),
        dt_control,
    )
    ctx.ik = IKSolver(world.robot, robot_only_model(world.robot), dt_control, scn.robot.base_pos)
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
    injector = FaultInjector(list(scn.faults), ctx, executor)

    act_idx = as_index(world.arm_act)
    # The physics step runs 500 times per simulated second: MjData's arrays are bound once
    # (they are views that never move), so the loop does no attribute lookups through MjData.
    qpos, ctrl = data.qpos, data.ctrl
    warnings = data.warning.number
    compute, mj_step, read_encoders = controller.compute, mujoco.mj_step, ctx.encoders.read
    time_limit = scn.physics.time_limit_s
    steppers = [obs.on_step for obs in observers if hasattr(obs, "on_step")]
    trace_truth = TraceTruth(ctx)
    steppers.append(trace_truth.on_step)
    true_force_sq = ctx.true_wrist_force_norm_sq
    max_force_sq = 0.0
    timed_out = False
    diverged: str | None = None
    end_stop: Stopper | None = None  # the controlled stop that ends the run
    settle_until = math.inf
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
        ctx.advance_gripper()
        for _ in range(n_sub):
            tau = compute(*read_encoders())
            if ctx.actuator_fault is not None:
                tau = ctx.actuator_fault.apply(tau)
            ctrl[act_idx] = tau
            mj_step(model, data)
            # the reported peak is the true force of every step, not a per-tick sample
            force_sq = true_force_sq()
            if force_sq > max_force_sq:  # noqa: PLR1730 (cheaper than max() per step)
                max_force_sq = force_sq
            for on_step in steppers:
                on_step(ctx)
            if data.time >= injector.next_t:
                injector.fire_due(data.time)
                checks = executor.active_checks
                stop = executor.stop if end_stop is None else end_stop
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
                    break
        ctx.tick += 1
        if not np.isfinite(qpos).all() or any(warnings[w] for w in _DIVERGED):
            diverged = f"physics diverged at t={ctx.t:.3f} s (state {executor.leaf})"
            break
        if ctx.t >= time_limit and not executor.done:
            timed_out = executor.violation is None
            executor.halt()

    outcome = executor.outcome or "failed"
    final_state = executor.final_state
    ctx.metrics.update(trace_truth.figures())  # before the success checks that read them
    success = evaluate(ctx, scn.success) if not diverged else dict.fromkeys(scn.success, False)
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
    abort_stop = executor.stop
    if executor.violation is not None and abort_stop is not None:
        metrics["abort_t"] = round(executor.violation_t or 0.0, 6)
        if abort_stop.stop_time_s is not None:
            metrics["stop_time_s"] = round(abort_stop.stop_time_s, 4)
        metrics["stop_distance_mm"] = round(abort_stop.distance_m * 1000.0, 3)
    if injector.injected:
        metrics["faults"] = injector.injected
    metrics["rest_speed_rad_s"] = round(float(np.max(np.abs(data.qvel[world.arm_dof]))), 5)
    if timed_out:
        metrics["time_limit_reached"] = True
    if diverged:
        metrics["error"] = diverged
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
    )
    for obs in observers:
        obs.on_end(ctx, executor, result)
    return result
