"""Batch throughput: episodes per second of pick_place with 1 and 2 workers, local and Ray.

Two figures per run: end to end (`run_batch` from start to summary, which includes starting
the workers or the local Ray) and steady state (from the first finished episode to the
last, which is what a long batch converges to). Each configuration runs `--repeats` times,
alternating; the speed-up is the median of the per-repeat ratios 2 workers / 1 worker.

    python bench/batch_scaling.py [--episodes 40] [--repeats 2] [--no-ray]
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path
from typing import Any

from orchestrator.batch import BatchConfig, run_batch


class _Clock:
    """A progress sink that only notes when each episode finished."""

    def __init__(self) -> None:
        self.times: list[float] = []

    def start(self, total: int, finished: list[dict[str, Any]]) -> None:
        del total, finished

    def advance(self, line: dict[str, Any]) -> None:
        del line
        self.times.append(time.perf_counter())

    def stop(self) -> None:
        pass


def measure(backend: str, workers: int, episodes: int, root: Path) -> tuple[float, float, float]:
    """(end-to-end, steady-state) episodes per second [1/s] and the success rate."""
    out = root / f"{backend}-{workers}-{time.monotonic_ns()}"
    clock = _Clock()
    t0 = time.perf_counter()
    summary = run_batch(
        BatchConfig("pick_place", episodes, out, workers=workers, backend=backend, record="none"),  # type: ignore[arg-type]
        progress=clock,
    )
    wall = time.perf_counter() - t0
    steady = (len(clock.times) - 1) / (clock.times[-1] - clock.times[0])
    return episodes / wall, steady, summary.success_rate


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=40)
    parser.add_argument("--repeats", type=int, default=2)
    parser.add_argument("--no-ray", action="store_true", help="Only the local backend.")
    args = parser.parse_args()
    backends = ["local"]
    if not args.no_ray:
        try:
            import ray  # noqa: F401
        except ImportError:
            print("ray is not installed: local backend only (pip install -e '.[ray]')")
        else:
            backends.append("ray")
    results: dict[tuple[str, int], list[tuple[float, float, float]]] = {}
    with tempfile.TemporaryDirectory() as tmp:
        for r in range(args.repeats):
            for backend in backends:
                for workers in (1, 2) if r % 2 == 0 else (2, 1):
                    fig = measure(backend, workers, args.episodes, Path(tmp))
                    results.setdefault((backend, workers), []).append(fig)
                    print(
                        f"  {backend:5s} {workers} worker(s): {fig[0]:5.2f} episodes/s end to end, "
                        f"{fig[1]:5.2f} steady, success {fig[2]:.1%}"
                    )
    med = statistics.median
    print(f"\npick_place, {args.episodes} episodes per run, median of {args.repeats} runs")
    print(f"{'backend':8s} {'workers':>7s} {'end-to-end [1/s]':>17s} {'steady [1/s]':>13s}")
    for (backend, workers), figs in results.items():
        e2e, steady = med(f[0] for f in figs), med(f[1] for f in figs)
        print(f"{backend:8s} {workers:7d} {e2e:17.2f} {steady:13.2f}")
    for backend in backends:
        one, two = results[(backend, 1)], results[(backend, 2)]
        e2e = med(b[0] / a[0] for a, b in zip(one, two, strict=True))
        steady = med(b[1] / a[1] for a, b in zip(one, two, strict=True))
        print(f"{backend}: 2 workers / 1 worker = {e2e:.2f}x end to end, {steady:.2f}x steady")


if __name__ == "__main__":
    main()
