"""Where the CPU time of a physics step goes: one episode, each hot function timed in place.

Every function below is wrapped with a CPU-time counter (`time.thread_time`, so time spent
waiting for a shared core is not counted) and reported in microseconds per physics step,
with the episode's CPU time per step. The wrappers cost ~0.3 us a call each: the "other"
row (runner loop, executor, skills not listed) carries that overhead.

    python bench/step_costs.py --scenario mobile_search --seed 1

Each wrapped call pays ~2 us of the clock's own cost (two `thread_time` calls at ~1.9 us on
this host, about half of it inside the measured interval): compare rows between checkouts,
not against a micro-benchmark.
"""

from __future__ import annotations

import argparse
import importlib
import time
from collections.abc import Callable
from typing import Any

import mujoco

NESTED = {
    "skill starts",
    "IKSolver.reference_step",
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
    ("orchestrator.guards.bank", "GuardBank", "_check_compiled"),
    ("orchestrator.engine.context", "Context", "wrist_force_norm_sq"),
    ("orchestrator.engine.context", "Context", "true_wrist_force_norm_sq"),
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
    ("orchestrator.engine.executor", "_start_skill", "skill starts"),
]
"""(module, function, row) of module-level functions: a state's skill starting (a move's
dry runs of the IK, an approach's planning) runs inside `Executor.tick`, once per state."""

_clock = time.thread_time


def _timed(fn: Callable[..., Any], acc: dict[str, list[float]], key: str) -> Callable[..., Any]:
    cell = acc.setdefault(key, [0.0, 0.0])

    def wrapper(*args: Any, **kwargs: Any) -> Any:
        t0 = _clock()
        try:
            return fn(*args, **kwargs)
        finally:
            cell[0] += _clock() - t0
            cell[1] += 1

    return wrapper


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", default="mobile_search", help="bundled name or path")
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()

    from orchestrator.engine import runner
    from orchestrator.language.load import load_scenario

    loaded = load_scenario(args.scenario)
    runner.run_episode(loaded, args.seed + 10_000)  # warm caches, as a batch worker would
    acc: dict[str, list[float]] = {}
    for mod, cls, meth in HOT:
        owner = getattr(importlib.import_module(mod), cls)
        setattr(owner, meth, _timed(getattr(owner, meth), acc, f"{cls}.{meth}"))
    for mod, name, key in MODULE_HOT:
        module = importlib.import_module(mod)
        setattr(module, name, _timed(getattr(module, name), acc, key))
    # on the compiled path (orchestrator/world/native.py) the context's wrist-force readings
    # are C methods bound per instance: time the true force there; the measured one is read
    # inside the bank's compiled check (its row includes it)
    make = runner.make_context

    def made(*a: Any, **k: Any) -> Any:
        ctx = make(*a, **k)
        if "true_wrist_force_norm_sq" in vars(ctx):
            key = "Context.true_wrist_force_norm_sq"
            ctx.true_wrist_force_norm_sq = _timed(ctx.true_wrist_force_norm_sq, acc, key)
        return ctx

    runner.make_context = made  # type: ignore[assignment]
    step = mujoco.mj_step
    mujoco.mj_step = _timed(step, acc, "mj_step")
    try:
        cpu0 = time.process_time()
        result = runner.run_episode(loaded, args.seed)
        cpu = time.process_time() - cpu0
    finally:
        mujoco.mj_step = step
    steps = acc["mj_step"][1]
    per_step = cpu / steps * 1e6
    print(
        f"{args.scenario} seed {args.seed}: {result.outcome}, {steps:.0f} steps, "
        f"{per_step:.0f} us CPU per step ({result.sim_time / cpu:.1f}x real time on CPU)"
    )
    listed = 0.0
    for key, (total, calls) in sorted(acc.items(), key=lambda kv: -kv[1][0]):
        if calls:
            us = total / steps * 1e6
            listed += 0.0 if key in NESTED else us
            label = f"  in tick: {key}" if key in NESTED else key
            each = total / calls * 1e6
            print(f"  {label:38s} {us:6.1f} us/step  ({calls:.0f} calls, {each:.1f} us each)")
    print(f"  {'other (loop, skills, wrappers)':38s} {per_step - listed:6.1f} us/step")


if __name__ == "__main__":
    main()
