"""Wall-time overhead of Rerun recording on an episode: paired runs, several seeds, median ratio.

Two measurements, both printed:

* `episode` (the figure the 1.3x bound is checked on): `run_episode` in this process, with and
  without a `RerunRecorder` writing a `.rrd` file; the recording is finished and the file
  complete when the call returns. One warm-up pair first, so the once-per-process costs
  (imports, Rerun's first sink) are not counted: this is what recording adds to a run, and
  what a batch worker pays per episode.
* `cli`: the whole `orchestrator run SCENARIO --seed N [--rrd PATH]` command in a fresh
  process. On top of the episode's overhead it pays the one-time `import rerun` (~0.35 s),
  which a command that does not record never does.

Each pair runs both variants back to back in alternating order (ABBA), so drift on a shared,
noisy machine cancels; the figure is the median of the per-pair ratios (with / without).

A third mode, `viewer`, measures what a reader waits for: each `.rrd` given with `--rrd`
opened in Rerun's web viewer in headless Chromium at 1600x900 (docs/make_images.py's
pieces; its requirements), the time until the page stops changing for 6 s (minus those 6 s),
and the file's size. Record before/after files of the same episodes and compare them in the
same run: software rendering on a shared machine makes the absolute times move with the load.

Usage:
    python bench/recording_overhead.py                 # both, 5 seeds x 3 pairs
    python bench/recording_overhead.py --mode episode --seeds 0 1 2 --pairs 5
    python bench/recording_overhead.py --mode viewer --rrd old/sorting.rrd new/sorting.rrd
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

MAX_RATIO = 1.3
"""The acceptance bound: a recorded run takes at most this many times the plain run."""


def _paired(
    seeds: list[int], pairs: int, plain: Callable[[int], float], recorded: Callable[[int], float]
) -> tuple[list[float], list[float], list[float]]:
    """Run `pairs` ABBA pairs per seed; return the plain and recorded times [s] and ratios."""
    t_plain: list[float] = []
    t_rec: list[float] = []
    ratios: list[float] = []
    for seed in seeds:
        for k in range(pairs):
            if k % 2 == 0:
                a = plain(seed)
                b = recorded(seed)
            else:
                b = recorded(seed)
                a = plain(seed)
            t_plain.append(a)
            t_rec.append(b)
            ratios.append(b / a)
    return t_plain, t_rec, ratios


def bench_episode(
    scenario: str, seeds: list[int], pairs: int, out: Path, cpu: bool = False
) -> float:
    """In-process episodes; returns the median ratio. `cpu`: CPU time of the process (all its
    threads, Rerun's writers included) instead of wall time: on a machine loaded by others,
    wall time mostly measures the others."""
    from orchestrator.engine.runner import run_episode
    from orchestrator.language.load import load_scenario
    from orchestrator.recording import RerunRecorder

    loaded = load_scenario(scenario)

    clock = time.process_time if cpu else time.perf_counter

    def plain(seed: int) -> float:
        t0 = clock()
        run_episode(loaded, seed)
        return clock() - t0

    def recorded(seed: int) -> float:
        t0 = clock()
        run_episode(loaded, seed, [RerunRecorder(path=out / f"episode_{seed}.rrd")])
        return clock() - t0

    plain(seeds[0]), recorded(seeds[0])  # warm-up: imports, caches, Rerun's first sink
    return _report("episode-cpu" if cpu else "episode", *_paired(seeds, pairs, plain, recorded))


def bench_cli(scenario: str, seeds: list[int], pairs: int, out: Path) -> float:
    """Fresh `orchestrator run` processes; returns the median ratio."""

    def run(seed: int, *extra: str) -> float:
        cmd = [sys.executable, "-m", "orchestrator.cli", "run", scenario, "--seed", str(seed)]
        t0 = time.perf_counter()
        proc = subprocess.run([*cmd, *extra], capture_output=True, text=True, check=False)
        wall = time.perf_counter() - t0
        if proc.returncode not in (0, 1, 3):
            raise SystemExit(f"{' '.join(cmd)} exited {proc.returncode}:\n{proc.stderr}")
        return wall

    def recorded(seed: int) -> float:
        return run(seed, "--rrd", str(out / f"cli_{seed}.rrd"))

    return _report("cli", *_paired(seeds, pairs, run, recorded))


def bench_viewer(paths: list[Path], out: Path) -> None:
    """Open each recording in the web viewer; print its size and the time until it settles."""
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "docs"))
    import make_images as mi

    lacking = mi.missing([mi.ViewerShot("x", "pick_place")])
    if lacking:
        raise SystemExit(f"the viewer mode needs: {lacking}")
    for path in paths:
        work = out / f"viewer_{path.stem}"
        work.mkdir(exist_ok=True)
        try:
            with mi._web_viewer(work, path) as (page, _), mi._browser() as browser:
                t0 = time.monotonic()
                browser.get(page)
                mi._loaded(browser, timeout_s=400.0, quiet_s=6.0)
                shown = time.monotonic() - t0 - 6.0 - 2.0  # the quiet time and the draw wait
            print(f"viewer  {path}  {path.stat().st_size / 1e6:6.2f} MB  shown in {shown:5.0f} s",
                  flush=True)  # fmt: skip
        except Exception as exc:  # noqa: BLE001 - report it, measure the others
            print(f"viewer  {path}  failed: {type(exc).__name__}: {exc}", flush=True)


def _report(name: str, t_plain: list[float], t_rec: list[float], ratios: list[float]) -> float:
    median = statistics.median(ratios)
    q = statistics.quantiles(ratios, n=4) if len(ratios) > 1 else [median] * 3
    extra = statistics.median(b - a for a, b in zip(t_plain, t_rec, strict=True))
    print(
        f"{name:8s} pairs {len(ratios):3d}  without {statistics.median(t_plain):.3f} s  "
        f"with --rrd {statistics.median(t_rec):.3f} s  (+{extra * 1e3:.0f} ms)  "
        f"ratio median {median:.3f} (IQR {q[0]:.3f}-{q[2]:.3f})",
        flush=True,
    )
    return median


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", default="pick_place")
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2, 3, 4])
    parser.add_argument("--pairs", type=int, default=3, help="Pairs per seed.")
    parser.add_argument("--mode", choices=("episode", "cli", "both", "viewer"), default="both")
    parser.add_argument("--rrd", type=Path, nargs="+", default=[], help="For --mode viewer.")
    parser.add_argument(
        "--cpu", action="store_true", help="episode: CPU time of the process, not wall time"
    )
    args = parser.parse_args(argv)
    episode = None
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp)
        if args.mode == "viewer":
            bench_viewer(args.rrd, out)
            return 0
        if args.mode in ("episode", "both"):
            episode = bench_episode(args.scenario, args.seeds, args.pairs, out, args.cpu)
        if args.mode in ("cli", "both"):
            bench_cli(args.scenario, args.seeds, args.pairs, out)
    if episode is None:
        return 0
    verdict = "ok" if episode <= MAX_RATIO else "OVER THE BOUND"
    print(f"recording overhead ratio (episode) {episode:.3f}, bound {MAX_RATIO}: {verdict}")
    return 0 if episode <= MAX_RATIO else 1


if __name__ == "__main__":
    sys.exit(main())
