"""The runner: one episode on simulated time — control ticks, physics steps, guards."""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

from ..exceptions import OrchestratorError
from ..language.load import LoadedScenario
from ..world.world import World
from .cell import Cell
from .context import Context
from .episode import (
    SETTLE_S,
    Episode,
    initial_blackboard,
    make_executor,
    make_guards,
)
from .executor import Executor
from .faults import FaultInjector
from .hardware import Hardware
from .invariants import InvariantsObserver
from .result import RunResult

__all__ = [
    "SETTLE_S",
    "WALL_GRACE_S",
    "Observer",
    "ResumeObserver",
    "RunState",
    "WallTimeExceeded",
    "drive",
    "initial_blackboard",
    "make_guards",
    "new_run",
    "run_episode",
    "tell_start",
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

    What else an observer implements it declares with the other extension points' protocols:
    `StepObserver` (engine/step.py, `on_step(ctx)` after every physics step) and
    `ResumeObserver` (`on_resume`, a restored run). Observers without them cost nothing there.
    """

    def on_start(self, ctx: Context, executor: Executor) -> None: ...
    def on_tick(self, ctx: Context, executor: Executor) -> None: ...
    def on_end(self, ctx: Context, executor: Executor, result: RunResult) -> None: ...


@runtime_checkable
class ResumeObserver(Protocol):
    """An observer that tells a resumed run from a fresh one: a run restored from a snapshot
    (or a live task restored with its session) calls `on_resume(ctx, executor)` instead of
    `on_start` (the recorder marks where the recording picks up)."""

    def on_resume(self, ctx: Context, executor: Executor) -> None: ...


def tell_start(
    observers: Sequence[Observer], ctx: Context, executor: Executor, resumed: bool
) -> None:
    """`on_resume` for a resumed run where an observer implements it, else `on_start`."""
    for obs in observers:
        if resumed and isinstance(obs, ResumeObserver):
            obs.on_resume(ctx, executor)
        else:
            obs.on_start(ctx, executor)


@dataclass
class RunState:
    """One episode of `orchestrator run`, between two control ticks: everything the rest of
    the run depends on (a snapshot records this as data, engine/snapshot).

    Attributes:
        loaded: The scenario (with the run's `--set`, `--fault` and `--event`).
        seed: The episode seed.
        episode: The machine on its world (context, executor, step loop).
        injector: The faults and timed events still to come.
        started: The machine's initial state has been entered.
    """

    loaded: LoadedScenario
    seed: int
    episode: Episode
    injector: FaultInjector
    started: bool = False

    @property
    def ctx(self) -> Context:
        return self.episode.ctx

    @property
    def cell(self) -> Hardware:
        return self.episode.ctx.cell

    @property
    def executor(self) -> Executor:
        return self.episode.executor


def new_run(loaded: LoadedScenario, seed: int, world: World | None = None) -> RunState:
    """The world of `loaded` built for `seed`, its machine not started yet.

    Args:
        loaded: The validated scenario.
        seed: Episode seed.
        world: The world of `loaded` already built for `seed` and never stepped (the one
            `prepare` compiled and checked the goals on, engine/prepare.py); None: build it.
    """
    scn = loaded.scenario
    cell = Cell.build(scn, seed, world)
    # the world's scenario: its blackboard holds the values drawn for this seed
    ctx = Context(cell, initial_blackboard(loaded.machine, cell.world.scenario.blackboard))
    executor = make_executor(loaded, ctx)
    injector = FaultInjector(list(scn.faults), ctx, executor, list(scn.events))
    loop = cell.loop
    loop.bind(ctx)
    loop.injector = injector
    return RunState(loaded, seed, Episode(loaded, ctx, executor, loop), injector)


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
    result = drive(new_run(loaded, seed), observers, max_wall_s)
    assert result is not None
    return result


def drive(
    run: RunState,
    observers: Sequence[Observer] | None = None,
    max_wall_s: float | None = None,
    until: Callable[[RunState], bool] | None = None,
) -> RunResult | None:
    """Run `run` (fresh, or restored from a snapshot) to its end, or until `until` says stop.

    Args:
        run: The run (`started` False: from the machine's initial state).
        observers: Told about the run on simulated time. A restored run tells each observer
            `on_resume(ctx, executor)` where it implements `ResumeObserver` (the recorder marks
            the resume), else `on_start`.
        max_wall_s: Wall-clock limit [s] of this part of the run (None: none).
        until: Asked before the machine starts and before every control tick: True stops
            the run there (a break point: the caller writes the snapshot).

    Returns:
        The result, or None if `until` stopped the run (observers are not told the end).

    Raises:
        WallTimeExceeded: The episode ran past `max_wall_s`.
    """
    observers = [*(observers or []), InvariantsObserver()]  # every run: engine/invariants.py
    wall0 = time.perf_counter()
    episode, injector, ctx, executor = run.episode, run.injector, run.ctx, run.executor
    episode.loop.set_observers(observers)
    episode.observers = list(observers)
    if until is not None and not run.started and until(run):
        return None
    tell_start(observers, ctx, executor, run.started)
    if not run.started:
        episode.start()
        injector.fire_due(ctx.t)  # faults at t = 0
        run.started = True
    wall_cut: str | None = None  # why the wall-clock limit ended the run
    wall_deadline = wall0 + max_wall_s if max_wall_s is not None else math.inf
    while True:
        if until is not None and until(run):
            return None
        if episode.tick():
            break
        if time.perf_counter() > wall_deadline:  # one clock read per control tick
            if wall_cut is not None:
                break
            wall_cut = (
                f"the episode ran past its wall-clock limit of {max_wall_s:g} s at "
                f"simulated t={ctx.t:.3f} s (state {executor.leaf}); the arm was stopped"
            )
            episode.halt(wall_cut)
            wall_deadline += WALL_GRACE_S  # for the controlled stop
    result = episode.result(run.seed, time.perf_counter() - wall0, injector.injected)
    if wall_cut:
        result.metrics["error"] = wall_cut
        if result.reason is None:
            result.reason = {
                "kind": "max_wall_s", "message": wall_cut, "value": round(
                    time.perf_counter() - wall0, 3), "limit": max_wall_s,
            }  # fmt: skip
    for obs in observers:
        obs.on_end(ctx, executor, result)
    ctx.cell.close()
    if wall_cut:
        raise WallTimeExceeded(wall_cut, result)
    return result
