"""The runner: one episode on simulated time — control ticks, physics steps, guards."""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from typing import Protocol

import numpy as np

from ..exceptions import OrchestratorError
from ..language.load import LoadedScenario
from ..language.scenario_checks import workspace_box
from ..robots import Controller
from ..skills.ik import IKSolver
from ..world.world import World, robot_only_model
from .blackboard import Blackboard
from .context import Context
from .episode import (
    SETTLE_S,
    Episode,
    initial_blackboard,
    make_controller,
    make_executor,
    make_guards,
)
from .executor import Executor
from .faults import FaultInjector
from .result import RunResult
from .step import StepLoop

__all__ = [
    "SETTLE_S",
    "WALL_GRACE_S",
    "Observer",
    "WallTimeExceeded",
    "initial_blackboard",
    "make_context",
    "make_guards",
    "run_episode",
]

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


class Observer(Protocol):
    """Watches a run (the Rerun recorder is one). Called on simulated time only.

    An observer may also define `on_step(ctx)`: it is then called after every physics step
    (bench/physical_honesty.py instruments the plant that way). Observers without it cost the
    physics step nothing.
    """

    def on_start(self, ctx: Context, executor: Executor) -> None: ...
    def on_tick(self, ctx: Context, executor: Executor) -> None: ...
    def on_end(self, ctx: Context, executor: Executor, result: RunResult) -> None: ...


def make_context(
    world: World, controller: Controller, blackboard: Blackboard, seed: int, dt_control: float
) -> Context:
    """The context of an episode (or of a live session): sensors, IK, the blackboard."""
    ctx = Context(world, controller, blackboard, np.random.default_rng([seed, 1]), dt_control)
    ctx.workspace_box = workspace_box(world.scenario)
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
    observers = list(observers or [])
    wall0 = time.perf_counter()
    scn = loaded.scenario
    world = World.build(scn, seed)
    controller = make_controller(world, seed)
    dt = float(world.model.opt.timestep)
    n_sub = max(1, round(1.0 / (scn.physics.control_hz * dt)))
    ctx = make_context(
        world,
        controller,
        # the world's scenario: its blackboard holds the values drawn for this seed
        initial_blackboard(loaded.machine, world.scenario.blackboard),
        seed,
        n_sub * dt,
    )
    executor = make_executor(loaded, ctx)
    injector = FaultInjector(list(scn.faults), ctx, executor, list(scn.events))
    loop = StepLoop(ctx, n_sub, injector)
    loop.set_observers(observers)
    episode = Episode(loaded, ctx, executor, loop, observers)
    wall_cut: str | None = None  # why the wall-clock limit ended the run
    wall_deadline = wall0 + max_wall_s if max_wall_s is not None else math.inf
    for obs in observers:
        obs.on_start(ctx, executor)
    episode.start()
    injector.fire_due(ctx.t)  # faults at t = 0
    while not episode.tick():
        if time.perf_counter() > wall_deadline:  # one clock read per control tick
            if wall_cut is not None:
                break
            wall_cut = (
                f"the episode ran past its wall-clock limit of {max_wall_s:g} s at "
                f"simulated t={ctx.t:.3f} s (state {executor.leaf}); the arm was stopped"
            )
            episode.halt(wall_cut)
            wall_deadline += WALL_GRACE_S  # for the controlled stop
    result = episode.result(seed, time.perf_counter() - wall0, injector.injected)
    if wall_cut:
        result.metrics["error"] = wall_cut
    for obs in observers:
        obs.on_end(ctx, executor, result)
    ctx.close()
    if wall_cut:
        raise WallTimeExceeded(wall_cut, result)
    return result
