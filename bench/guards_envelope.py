"""Does the guards' envelope test need its compiled twin? Whole episodes, paired in one process.

Each pair runs the same scenario and seed twice in this process: once with the guards'
envelope tested by the compiled module (world/_native.c) and once by its Python definition
(guards/bank.py), in alternating order (ABBA), so drift of a shared machine cancels. Only the
envelope test differs between the two: the wrist sensor's per-step readings stay compiled in
both. The figure is the median of the per-pair CPU-time ratios (compiled / Python), with its
interquartile range; the load average is printed with it.

    python bench/guards_envelope.py [--pairs 10] [--scenario pick_place]

It also times one `GuardBank.check` per physics step mid-episode both ways (best of 5
repeats: the least disturbed by other processes) against the run's CPU time per step.

It needs a checkout that still has the compiled envelope test (before issue 41 removed it
on this measurement); on one without, it says so and measures nothing. To run it on the
last commit that had it, as measured for BENCHMARKS.md (the extension built by this venv):

    git archive 0d89b57 | tar -x -C /tmp/base && cd /tmp/base
    for d in robots machines scenarios skills; do cp -r $d orchestrator/; done
    python setup.py build_ext --inplace   # the old extension, with its Envelope
    PYTHONPATH=/tmp/base python /path/to/bench/guards_envelope.py --pairs 10
"""

from __future__ import annotations

import argparse
import math
import os
import statistics
import time

from orchestrator.engine.runner import run_episode
from orchestrator.guards import bank
from orchestrator.language.load import load_scenario


def _wall(loaded, seed: int) -> float:
    """The episode's CPU time in this process (less sensitive than wall time to a loaded
    machine's other processes)."""
    t0 = time.process_time()
    result = run_episode(loaded, seed)
    wall = time.process_time() - t0
    if result.outcome != "succeeded":
        raise SystemExit(f"seed {seed} did not succeed ({result.outcome}): not a fair pair")
    return wall


def _per_step(loaded, seed: int, calls: int = 20_000) -> tuple[float, float, float]:
    """At tick 150 of an episode (moving, carrying): one `GuardBank.check` per call with the
    envelope in C and in Python [us] (best of 5 repeats), and the episode's CPU time per
    physics step [us]."""
    found: dict[str, float] = {}

    class Probe:
        def on_start(self, ctx, executor) -> None:
            pass

        def on_tick(self, ctx, executor) -> None:
            if ctx.tick != 150:
                return
            for label, make in (("c", compiled_bank), ("py", python_bank)):
                checker = make(executor, ctx)
                best = math.inf
                for _ in range(5):
                    t0 = time.process_time()
                    for _ in range(calls):
                        checker(ctx)
                    best = min(best, (time.process_time() - t0) / calls * 1e6)
                found[label] = best

        def on_end(self, *args) -> None:
            pass

    compiled = bank._compiled  # type: ignore[attr-defined]

    def compiled_bank(executor, ctx):
        return bank.GuardBank(executor.active_guards, ctx).check

    def python_bank(executor, ctx):
        bank._compiled = lambda *a, **k: None  # type: ignore[attr-defined]
        try:
            return bank.GuardBank(executor.active_guards, ctx).check
        finally:
            bank._compiled = compiled  # type: ignore[attr-defined]

    t0 = time.process_time()
    result = run_episode(loaded, seed, [Probe()])
    cpu = time.process_time() - t0
    steps = round(result.to_json_dict()["sim_time"] / loaded.scenario.physics.timestep_s)
    return found["c"], found["py"], cpu / steps * 1e6


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--pairs", type=int, default=10, help="Paired runs (seeds).")
    parser.add_argument("--scenario", default="pick_place")
    args = parser.parse_args()
    compiled = getattr(bank, "_compiled", None)
    if compiled is None:
        raise SystemExit(
            "this checkout has no compiled envelope test (removed in issue 41): run this bench "
            "on one that has, e.g. with PYTHONPATH pointing at an export of commit 0d89b57"
        )

    def python_only(*_args, **_kwargs):  # the envelope tested by GuardBank.inside
        return None

    loaded = load_scenario(args.scenario)

    def run(use_c: bool, seed: int) -> float:
        bank._compiled = compiled if use_c else python_only  # type: ignore[attr-defined]
        try:
            return _wall(loaded, seed)
        finally:
            bank._compiled = compiled  # type: ignore[attr-defined]

    run(True, 10_000)  # warm the caches once, as a batch worker would
    run(False, 10_000)
    load0 = os.getloadavg()[0]
    ratios = []
    for i in range(args.pairs):
        order = (True, False) if i % 2 == 0 else (False, True)
        walls = {use_c: run(use_c, i) for use_c in order}
        ratios.append(walls[True] / walls[False])
    q1, med, q3 = statistics.quantiles(ratios, n=4)
    load1 = os.getloadavg()[0]
    print(
        f"{args.scenario}: envelope in C / envelope in Python, CPU time = {med:.3f} "
        f"(IQR {q1:.3f}-{q3:.3f}, {args.pairs} pairs; load average {load0:.1f} -> {load1:.1f} "
        f"on {os.cpu_count()} cores)"
    )
    c_us, py_us, step_us = _per_step(loaded, 0)
    print(
        f"  per physics step: GuardBank.check {c_us:.2f} us (C) vs {py_us:.2f} us (Python); "
        f"a whole physics step of the run {step_us:.0f} us: the C test saves "
        f"{(py_us - c_us) / step_us:.1%} of a step"
    )


if __name__ == "__main__":
    main()
