"""Batch throughput: episodes per second of pick_place with 1 and 2 workers, local and Ray.

Figures per run: end to end (`run_batch` from start to summary, which includes starting
the workers or the local Ray, but not the local backend's one-time fork server start, done
before measuring), steady state (from the first finished episode to the last,
which is what a long batch converges to), and the mean wall time of one episode as its worker
measured it (when it grows with 2 workers, the cores were shared: on a busy machine, with
other processes), and how busy the worker slots were (the batch machinery's own overhead:
startup, dispatch, writing results). Each configuration runs `--repeats` times,
alternating; the speed-up is the median of the per-repeat ratios 2 workers / 1 worker.

    python bench/batch_scaling.py [--episodes 40] [--repeats 2] [--no-ray]
"""

from __future__ import annotations

import argparse
import json
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


Figures = tuple[float, float, float, float, float]
"""End-to-end and steady-state episodes per second [1/s], mean episode wall time [s] as the
worker measured it (it grows when the workers compete for the cores), how busy the worker
slots were (sum of episode wall times / (workers x batch wall time)), success rate."""


def measure(backend: str, workers: int, episodes: int, root: Path) -> Figures:
    """Run one batch and return its figures."""
    out = root / f"{backend}-{workers}-{time.monotonic_ns()}"
    clock = _Clock()
    t0 = time.perf_counter()
    summary = run_batch(
        BatchConfig("pick_place", episodes, out, workers=workers, backend=backend, record="none"),  # type: ignore[arg-type]
        progress=clock,
    )
    wall = time.perf_counter() - t0
    steady = (len(clock.times) - 1) / (clock.times[-1] - clock.times[0])
    lines = [json.loads(t) for t in (out / "results.jsonl").read_text().splitlines()]
    busy = sum(ln["wall_time"] for ln in lines) / (workers * wall)
    episode_wall = statistics.fmean(ln["wall_time"] for ln in lines)
    return episodes / wall, steady, episode_wall, busy, summary.success_rate


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
    results: dict[tuple[str, int], list[Figures]] = {}
    with tempfile.TemporaryDirectory() as tmp:
        # The local backend's fork server lives as long as this process: start it before
        # measuring, so that neither worker count pays its start alone.
        measure("local", 1, 2, Path(tmp))
        for r in range(args.repeats):
            for backend in backends:
                for workers in (1, 2) if r % 2 == 0 else (2, 1):
                    fig = measure(backend, workers, args.episodes, Path(tmp))
                    results.setdefault((backend, workers), []).append(fig)
                    print(
                        f"  {backend:5s} {workers} worker(s): {fig[0]:5.2f} episodes/s end to end, "
                        f"{fig[1]:5.2f} steady, episode {fig[2] * 1e3:.0f} ms, busy {fig[3]:.0%}, "
                        f"success {fig[4]:.1%}"
                    )
    med = statistics.median
    print(f"\npick_place, {args.episodes} episodes per run, median of {args.repeats} runs")
    print(
        f"{'backend':8s} {'workers':>7s} {'end-to-end [1/s]':>17s} {'steady [1/s]':>13s} "
        f"{'episode [ms]':>13s} {'busy':>6s}"
    )
    for (backend, workers), figs in results.items():
        e2e, steady, ep, busy = (med(f[k] for f in figs) for k in range(4))
        print(f"{backend:8s} {workers:7d} {e2e:17.2f} {steady:13.2f} {ep * 1e3:13.0f} {busy:6.0%}")
    for backend in backends:
        one, two = results[(backend, 1)], results[(backend, 2)]
        e2e = med(b[0] / a[0] for a, b in zip(one, two, strict=True))
        steady = med(b[1] / a[1] for a, b in zip(one, two, strict=True))
        print(f"{backend}: 2 workers / 1 worker = {e2e:.2f}x end to end, {steady:.2f}x steady")


if __name__ == "__main__":
    main()
