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
from ..language.machine import guard_entries
from ..robots import Controller
from ..skills.ik import IKSolver
from ..world.world import World, as_index, robot_only_model
from .blackboard import Blackboard
from .context import Context
from .executor import Executor
from .result import RunResult
from .success import evaluate

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
    """Watches a run (the Rerun recorder is one). Called on simulated time only."""

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
    controller = Controller(world.robot, float(world.model.opt.timestep))
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
    executor = Executor(loaded.machine, ctx, make_guards(scn.guards, ctx), scn.physics.safe_stop_s)

    q_idx, v_idx = as_index(world.robot_qpos), as_index(world.robot_dof)
    act_idx = as_index(world.arm_act)
    # The physics step runs 500 times per simulated second: MjData's arrays are bound once
    # (they are views that never move), so the loop does no attribute lookups through MjData.
    qpos, qvel, ctrl = data.qpos, data.qvel, data.ctrl
    warnings = data.warning.number
    compute, mj_step = controller.compute, mujoco.mj_step
    time_limit = scn.physics.time_limit_s
    max_force_sq = 0.0
    timed_out = False
    diverged: str | None = None
    for obs in observers:
        obs.on_start(ctx, executor)
    executor.start()
    settle_until: float | None = None
    while True:
        if not executor.done:
            executor.tick()
        for obs in observers:
            obs.on_tick(ctx, executor)
        if executor.done:
            if executor.outcome == "aborted":
                break
            if settle_until is None:
                settle_until = ctx.t + SETTLE_S
                controller.hold(controller.q_d.copy())
            if ctx.t >= settle_until - 1e-9:
                break
        guards = executor.active_guards  # states change in tick() or abort(), never between
        for _ in range(n_sub):
            ctrl[act_idx] = compute(qpos[q_idx], qvel[v_idx])
            mj_step(model, data)
            for guard in guards:
                violation = guard.check(ctx)
                if violation is not None:
                    executor.abort(violation)
                    guards = executor.active_guards  # none while the safety response runs
                    break
        ctx.tick += 1
        max_force_sq = max(max_force_sq, ctx.wrist_force_norm_sq())
        if not np.isfinite(qpos).all() or any(warnings[w] for w in _DIVERGED):
            diverged = f"physics diverged at t={ctx.t:.3f} s (state {executor.leaf})"
            break
        if ctx.t >= time_limit and not executor.done:
            timed_out = True
            break

    if executor.done:
        outcome = executor.outcome
        final_state = executor.final_state
    else:
        outcome = "failed"
        final_state = executor.leaf
    success = evaluate(ctx, scn.success) if not diverged else dict.fromkeys(scn.success, False)
    if outcome == "succeeded" and not all(success.values()):
        outcome = "failed"
    metrics: dict[str, Any] = {
        "cycle_time": round(executor.final_t, 6) if executor.final_t is not None else None,
        "max_wrist_force_n": round(math.sqrt(max_force_sq), 4),
        "control_ticks": ctx.tick,
    }
    metrics.update(ctx.metrics)
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
