"""What the invariants cost a run: CPU time of the same episodes with and without them.

Every run measures its invariants (engine/invariants.py: an observer called after every
physics step). This bench runs each seed twice in one process, paired and in alternating
order (with, without; then without, with on the next seed), `--repeat` times, timing each
episode's CPU time (`time.process_time`, so other processes on a shared host count less; the
garbage collector run before each), and reports the median and worst over the seeds of the
ratio of each condition's least CPU (one pair alone swung 0.97-1.39 on a quiet host: the least
of a few is the run's own cost). "Without" swaps the observer for one with no per-step hook
(the run is otherwise the same, bit for bit: the observer only reads).

    python bench/invariants_cost.py                       # sorting, seeds 0-3
    python bench/invariants_cost.py --scenario pick_place --seeds 6 --repeat 3
    python bench/invariants_cost.py --amplify 20     # the per-step work done 20 times a step

The per-step check costs a few microseconds against a step of a few hundred: on a shared host
the spread of one episode's CPU is wider than that. `--amplify K` makes the "with" run call the
observer's `on_step` K times after every physics step (the same readings and comparisons each
time; the loop around them counts too, so the figure errs high) and reports the cost of one
call per step as `1 + (with_K - without) / (K * without)`: the effect is K times larger than
the noise it is read against.
"""

from __future__ import annotations

import argparse
import gc
import statistics
import time

from orchestrator.engine import runner
from orchestrator.engine.invariants import InvariantsObserver
from orchestrator.engine.runner import run_episode
from orchestrator.language.load import load_scenario


class _Off:
    """The observer's place in the run, with nothing measured."""

    def on_start(self, ctx, executor) -> None:
        pass

    def on_tick(self, ctx, executor) -> None:
        pass

    def on_end(self, ctx, executor, result) -> None:
        pass


class _Amplified(InvariantsObserver):
    """The observer with its per-step work done `times` times a step."""

    times = 1

    def on_step(self, ctx) -> None:
        step = super().on_step
        for _ in range(self.times):
            step(ctx)


def _episode(loaded, seed: int, on: bool) -> tuple[float, dict]:
    runner.InvariantsObserver = _Amplified if on else _Off  # type: ignore[misc,assignment]
    gc.collect()
    t0 = time.process_time()
    result = run_episode(loaded, seed)
    cpu = time.process_time() - t0
    runner.InvariantsObserver = InvariantsObserver  # type: ignore[misc]
    out = result.to_json_dict()
    out.pop("wall_time")
    out.pop("invariants", None)
    return cpu, out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", default="sorting")
    parser.add_argument("--seeds", type=int, default=4)
    parser.add_argument("--repeat", type=int, default=3, help="pairs per seed (the least CPU)")
    parser.add_argument("--amplify", type=int, default=1, help="on_step calls per physics step")
    args = parser.parse_args()
    _Amplified.times = args.amplify
    loaded = load_scenario(args.scenario)
    _episode(loaded, 0, True)  # warm-up: imports, compiled models, caches
    ratios = []
    for seed in range(args.seeds):
        order = (True, False) if seed % 2 == 0 else (False, True)
        cpu: dict[bool, float] = {True: float("inf"), False: float("inf")}
        same: dict[bool, dict] = {}
        for _ in range(args.repeat):
            for on in order:
                took, same[on] = _episode(loaded, seed, on)
                cpu[on] = min(cpu[on], took)
        assert same[True] == same[False], "the observer changed the run"
        ratios.append(1.0 + (cpu[True] - cpu[False]) / (args.amplify * cpu[False]))
        print(f"seed {seed}: with (x{args.amplify}) {cpu[True]:.2f} s, without {cpu[False]:.2f} s "
              f"CPU, one check a step: {ratios[-1]:.4f}", flush=True)  # fmt: skip
    print(f"{args.scenario}: {len(ratios)} seeds, CPU with/without invariants (x{args.amplify}, "
          f"scaled to one check a step): median {statistics.median(ratios):.4f}, worst "
          f"{max(ratios):.4f} (target <= 1.05)")  # fmt: skip


if __name__ == "__main__":
    main()
