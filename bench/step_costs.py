"""Where the CPU time of a physics step goes: one episode, each hot function timed in place.

Every function below is wrapped with a CPU-time counter (`time.thread_time`, so time spent
waiting for a shared core is not counted) and reported in microseconds per physics step,
with the episode's CPU time per step. The IK's solves (`IKSolver.reference_step`) are split
into those inside a skill's start (a move's dry runs and time fitting, a grasp plan's checks)
and the live ones of the ticks.

    python bench/step_costs.py --scenario sorting --seed 1
    python bench/step_costs.py --hand-written --seed 0   # bench/overhead.py's loop, for scale

The wrappers cost time of their own: `thread_time` is a system call (~1.9 us on this host),
two per wrapped call, about half of each inside the interval it measures. The bench measures
that on a wrapped call of nothing before the episode and prints it: what all the wrapped calls
added to the episode's CPU per step (the uninstrumented figure is the total less that, or
bench/realtime.py's), and per row the clock's part inside it, taken off in the last column.
A row that contains other timed rows (`Executor.tick`, the skill starts) also contains their
wrappers' whole cost. Compare rows between checkouts, not against a micro-benchmark.
"""

from __future__ import annotations

import argparse
import importlib
import math
import sys
import time
from collections.abc import Callable
from functools import partial
from pathlib import Path
from typing import Any

import mujoco

NESTED = {
    "skill starts",
    "IKSolver.reference_step",
    "IKSolver.reference_step, live",
    "IKSolver.reference_step, skill starts",
    "IKSolver.follow",
    "BaseMap.clearance",
    "BaseMap.reach_clear",
    "BaseMotion.command",
}
"""Rows called from inside `Executor.tick` (its row includes them)."""

HOT: list[tuple[str, str, str]] = [
    ("orchestrator.robots.controller", "Controller", "compute"),
    ("orchestrator.world.sensors", "JointEncoders", "read"),
    ("orchestrator.guards.bank", "GuardBank", "inside"),
    ("orchestrator.world.wrist", "WristSensor", "_py_norm_sq"),  # the Python path's readers
    ("orchestrator.world.wrist", "WristSensor", "_py_true_norm_sq"),
    ("orchestrator.engine.trace_truth", "TraceTruth", "on_step"),
    ("orchestrator.engine.executor", "Executor", "tick"),
    ("orchestrator.skills.ik", "IKSolver", "reference_step"),
    ("orchestrator.skills.ik", "IKSolver", "follow"),
    ("orchestrator.skills.base_map", "BaseMap", "clearance"),
    ("orchestrator.skills.base_map", "BaseMap", "reach_clear"),
    ("orchestrator.skills.base_motion", "BaseMotion", "command"),
]
"""(module, class, method) of the functions on or near the per-step path."""

MODULE_HOT: list[tuple[str, str, str]] = [
    ("orchestrator.engine.regions", "_start_skill", "skill starts"),
]
"""(module, function, row) of module-level functions: a state's skill starting (a move's
dry runs of the IK, an approach's planning) runs inside `Executor.tick`, once per state."""

_clock = time.thread_time


def _timed(
    fn: Callable[..., Any],
    acc: dict[str, list[float]],
    key: str,
    depth: list[int] | None = None,
    key_inside: str | None = None,
) -> Callable[..., Any]:
    """`fn` counting its calls and CPU time into `acc[key]`; with `depth`, a call made while
    `depth[0] > 0` (inside a skill's start) counts into `acc[key_inside]` instead."""
    cell = acc.setdefault(key, [0.0, 0.0])
    inner = acc.setdefault(key_inside, [0.0, 0.0]) if key_inside is not None else cell

    def wrapper(*args: Any, **kwargs: Any) -> Any:
        c = inner if depth is not None and depth[0] > 0 else cell
        t0 = _clock()
        try:
            return fn(*args, **kwargs)
        finally:
            c[0] += _clock() - t0
            c[1] += 1

    return wrapper


def _nesting(fn: Callable[..., Any], depth: list[int]) -> Callable[..., Any]:
    """`fn` with `depth[0]` raised while it runs."""

    def wrapper(*args: Any, **kwargs: Any) -> Any:
        depth[0] += 1
        try:
            return fn(*args, **kwargs)
        finally:
            depth[0] -= 1

    return wrapper


def _calibrate(rounds: int = 5, calls: int = 20_000) -> tuple[float, float]:
    """What one wrapped call costs on top of the call [s]: in all (the process's CPU time
    over many calls of nothing, wrapped against bare), and the part of it inside the interval
    the wrapper measures. Best of `rounds`."""

    def nothing() -> None:
        return None

    total, inside = math.inf, math.inf
    for _ in range(rounds):
        acc: dict[str, list[float]] = {}
        wrapped = _timed(nothing, acc, "nothing")
        c0 = time.process_time()
        for _ in range(calls):
            nothing()
        bare = time.process_time() - c0
        c0 = time.process_time()
        for _ in range(calls):
            wrapped()
        total = min(total, (time.process_time() - c0 - bare) / calls)
        inside = min(inside, acc["nothing"][0] / calls)
    return total, inside


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", default="mobile_search", help="bundled name or path")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument(
        "--hand-written",
        action="store_true",
        help="time bench/overhead.py's hand-written pick_place loop instead (the same plant, "
        "controller and motion generator, no framework; its moves' path fitting in the "
        "skill-starts rows)",
    )
    args = parser.parse_args()
    if args.hand_written:
        args.scenario = "pick_place"

    from orchestrator.engine import runner
    from orchestrator.language.load import load_scenario

    loaded = load_scenario(args.scenario)
    runner.run_episode(loaded, args.seed + 10_000)  # warm caches, as a batch worker would
    if args.hand_written:
        sys.path.insert(0, str(Path(__file__).resolve().parent))
        import overhead  # bench/overhead.py

        overhead.HandWritten(loaded.scenario, args.seed + 10_000).run()
    per_call, inside_call = _calibrate()
    acc: dict[str, list[float]] = {}
    depth = [0]  # > 0 inside a skill's start
    for mod, cls, meth in HOT:
        owner = getattr(importlib.import_module(mod), cls)
        key = f"{cls}.{meth}"
        split = None
        if key == "IKSolver.reference_step":  # the IK's solves: in a skill's start or live
            key, split = f"{key}, live", f"{key}, skill starts"
        setattr(owner, meth, _timed(getattr(owner, meth), acc, key, depth, split))
    for mod, name, key in MODULE_HOT:
        module = importlib.import_module(mod)
        setattr(module, name, _timed(_nesting(getattr(module, name), depth), acc, key))
    episode = partial(_framework, runner.run_episode, loaded, args.seed)
    nested, prefix = NESTED, "in tick"
    if args.hand_written:
        for name in ("fit_path_to_joints", "feasible_time_scale"):  # a move's start
            fn = _nesting(getattr(overhead, name), depth)
            setattr(overhead, name, _timed(fn, acc, "skill starts"))
        # no executor: the IK's rows are not inside a tick; the solves of a move's start are
        # inside its row
        nested, prefix = {"IKSolver.reference_step, skill starts"}, "in starts"
        episode = partial(_hand_written, overhead.HandWritten, loaded.scenario, args.seed)
    # the wrist sensor's readings are chosen per sensor (world/wrist.py: C methods on the
    # compiled path): time the true force there; the measured one is read inside the bank's
    # envelope test (its row includes it)
    build = runner.Cell.build

    def built(*a: Any, **k: Any) -> Any:
        cell = build(*a, **k)
        key = "WristSensor.true_norm_sq"
        cell.wrist.true_norm_sq = _timed(cell.wrist.true_norm_sq, acc, key)
        return cell

    runner.Cell.build = built  # type: ignore[method-assign]
    step = mujoco.mj_step
    mujoco.mj_step = _timed(step, acc, "mj_step")
    try:
        cpu0 = time.process_time()
        outcome, sim_time = episode()
        cpu = time.process_time() - cpu0
    finally:
        mujoco.mj_step = step
    steps = acc["mj_step"][1]
    per_step = cpu / steps * 1e6
    wrapped = sum(calls for _, calls in acc.values())
    added = wrapped * per_call / steps * 1e6
    name = "hand-written pick_place" if args.hand_written else args.scenario
    print(
        f"{name} seed {args.seed}: {outcome}, {steps:.0f} steps, "
        f"{per_step:.0f} us CPU per step ({sim_time / cpu:.1f}x real time on CPU)"
    )
    print(
        f"  the wrappers: {wrapped / steps:.1f} timed calls per step at {per_call * 1e6:.2f} us "
        f"each ({inside_call * 1e6:.2f} us inside the row) add {added:.1f} us/step: "
        f"{per_step - added:.0f} us CPU per step without them"
    )
    listed = 0.0
    print(f"  {'':48s} {'us/step':>7s}  {'calls':>7s} {'us each':>9s} {'less clock':>11s}")
    for key, (total, calls) in sorted(acc.items(), key=lambda kv: -kv[1][0]):
        if calls:
            us = total / steps * 1e6
            listed += 0.0 if key in nested else us
            label = f"  {prefix}: {key}" if key in nested else key
            each = total / calls * 1e6
            own = (total - calls * inside_call) / steps * 1e6
            print(f"  {label:48s} {us:7.1f}  {calls:7.0f} {each:9.1f} {own:11.1f}")
    print(f"  {'other (loop, skills, wrappers)':48s} {per_step - listed:7.1f}")


def _framework(run: Callable[..., Any], loaded: Any, seed: int) -> tuple[str, float]:
    """The framework's episode of `seed`: its outcome and simulated time [s]."""
    result = run(loaded, seed)
    return result.outcome, result.sim_time


def _hand_written(loop: Callable[..., Any], scenario: Any, seed: int) -> tuple[str, float]:
    """bench/overhead.py's loop on `seed`: its outcome and simulated time [s]."""
    run = loop(scenario, seed)
    return ("succeeded" if run.run() else "failed"), run.t


if __name__ == "__main__":
    main()
