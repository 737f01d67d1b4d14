"""Compute time of the framework's two loops, measured inside real pick_place episodes.

* physics step (500 Hz): the controller (`Controller.compute`) plus every active guard's
  `check` — the framework's work per step; `mujoco.mj_step` is reported on its own.
* control tick (100 Hz): `Executor.tick`, i.e. the state machine plus the active skill's
  `step`, which runs the mink IK.

The methods are wrapped with timers, nothing in the framework is changed. Two clocks:
wall (`perf_counter_ns`, what a real-time loop sees, including any time the OS ran another
process) and CPU (`thread_time_ns`, this thread's own compute, robust to a busy machine).
The timers add well under 1 us per wrapped call, included in the figures.

    python bench/tick_latency.py [--episodes 10]
"""

from __future__ import annotations

import argparse
import functools
import time
from array import array
from collections.abc import Callable
from typing import Any

import mujoco
import numpy as np
from orchestrator.robots import Controller

from orchestrator.engine.executor import Executor
from orchestrator.engine.runner import run_episode
from orchestrator.guards import GUARDS
from orchestrator.language.load import load_scenario


class Samples:
    """Wall and CPU times of one kind of call [ns], kept in arrays the GC never scans (a list
    of tuples would make the collector's pauses part of the figures)."""

    def __init__(self) -> None:
        self.wall = array("q")
        self.cpu = array("q")

    def append(self, wall_ns: int, cpu_ns: int) -> None:
        self.wall.append(wall_ns)
        self.cpu.append(cpu_ns)

    def add_to_last(self, wall_ns: int, cpu_ns: int) -> None:
        self.wall[-1] += wall_ns
        self.cpu[-1] += cpu_ns

    def clear(self) -> None:
        del self.wall[:], self.cpu[:]


STEP = Samples()
"""Per physics step: controller + guards."""
MJ_STEP = Samples()
"""Per physics step: mujoco.mj_step."""
TICK = Samples()
"""Per control tick: Executor.tick."""


def _timed(fn: Callable[..., Any], sink: Callable[[int, int], None]) -> Callable[..., Any]:
    wall, cpu = time.perf_counter_ns, time.thread_time_ns

    @functools.wraps(fn)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        w0, c0 = wall(), cpu()
        out = fn(*args, **kwargs)
        sink(wall() - w0, cpu() - c0)
        return out

    return wrapper


def instrument() -> None:
    """Wrap the controller, the guards, mj_step and the executor's tick with timers."""
    Controller.compute = _timed(Controller.compute, STEP.append)  # type: ignore[method-assign]
    for cls in GUARDS.values():
        cls.check = _timed(cls.check, STEP.add_to_last)  # type: ignore[method-assign]
    mujoco.mj_step = _timed(mujoco.mj_step, MJ_STEP.append)
    Executor.tick = _timed(Executor.tick, TICK.append)  # type: ignore[method-assign]


def _row(name: str, samples: Samples) -> str:
    cells = []
    for ns in (samples.wall, samples.cpu):
        us = np.frombuffer(ns, dtype=np.int64) / 1000.0
        p50, p99 = np.percentile(us, [50, 99])
        cells.append(f"{p50:7.1f} {p99:7.1f} {us.max():8.1f}")
    return f"{name:36s} {len(samples.wall):7d}   {cells[0]}   {cells[1]}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=10, help="Episodes (seeds 0..N-1).")
    args = parser.parse_args()
    loaded = load_scenario("pick_place")
    run_episode(loaded, 10_000)  # warm-up: imports, caches
    instrument()
    for samples in (STEP, MJ_STEP, TICK):
        samples.clear()
    outcomes = [run_episode(loaded, seed).outcome for seed in range(args.episodes)]
    print(f"pick_place, {args.episodes} episodes ({outcomes.count('succeeded')} succeeded)")
    print(f"{'':36s} {'':7s}   {'wall [us]':^24s}   {'CPU [us]':^24s}")
    head = f"{'p50':>7s} {'p99':>7s} {'max':>8s}"
    print(f"{'':36s} {'samples':>7s}   {head}   {head}")
    print(_row("physics step: controller + guards", STEP))
    print(_row("physics step: mujoco.mj_step", MJ_STEP))
    print(_row("control tick: executor + skill + IK", TICK))


if __name__ == "__main__":
    main()
