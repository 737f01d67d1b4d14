"""The physics timestep chosen by measurement: every physical-honesty row at several steps.

For each scenario and each timestep (`physics.timestep_s` overridden on the loaded scenario,
`control_hz` kept), runs the seeds through bench/physical_honesty.py's per-step probe (its
`run`: outcome, joint speed / acceleration / torque ratios against the datasheet, steps above
the acceleration limit, saturated steps, finger speed, penetrations, true wrist force) and puts
the figures side by side: worst and p50 of each probe figure and of each numeric metric of the
run (placement error, surgical cross-track and force RMS, ...), one column per timestep.

Then the CPU cost: the first `--cpu-seeds` seeds again without the probe, the timesteps
interleaved seed by seed in one process (so the machine's load hits them alike), after one
warm-up episode per timestep; process CPU per simulated second, and the load from `uptime`.

A control tick must be a whole number of physics steps (the scenario schema refuses 100 Hz at
4 ms: 2.5 steps); where the scenario's rate does not fit a timestep, the study sets
`physics.control_hz` to the rate of the nearest whole number of steps (`round`, as the runner
did before it was refused: 125 Hz at 4 ms), and the table's header says the rate each column
ran at.

    python bench/timestep_study.py --only pick_place=20,sorting=4 --json /tmp/ts.json
    python bench/timestep_study.py --only surgical=5@1000 --timesteps 0.002 0.004
"""

from __future__ import annotations

import argparse
import json
import os
import time
from typing import Any

import numpy as np
from physical_honesty import FIGURES, LIMITS, metric_keys, run

from orchestrator.engine.runner import run_episode
from orchestrator.language.load import load_scenario

STUDY = {
    "pick_place": (20, 0),
    "sorting": (4, 0),
    "pick_place_vision": (4, 0),
    "mobile_search": (3, 0),
    "stack": (4, 0),
    "reach_random": (5, 0),
    "sorting_conveyor": (2, 0),
    "surgical": (5, 1000),
    "surgical_complication": (5, 1000),
}
"""Scenario -> (seeds, first seed) studied by default (surgical's seeds as its docs use)."""


def _control_hz(name: str, dt: float, extra: list[str]) -> float:
    """The control rate of scenario `name` at timestep `dt` [s]: its own if a tick is a whole
    number of steps, else the rate of the nearest whole number of steps [Hz]."""
    hz = load_scenario(name, extra or None).scenario.physics.control_hz
    return 1.0 / (max(1, round(1.0 / (hz * dt))) * dt)


def _override(name: str, dt: float, extra: list[str]) -> list[str]:
    """`extra` and the overrides that run scenario `name` at timestep `dt` [s]."""
    return [
        *extra,
        f"physics.timestep_s={dt!r}",
        f"physics.control_hz={_control_hz(name, dt, extra)!r}",
    ]


def study(name: str, seeds: range, timesteps: list[float], extra: list[str]) -> dict:
    """Every timestep's probe rows for `seeds` of scenario `name`."""
    return {dt: run(name, seeds, _override(name, dt, extra)) for dt in timesteps}


def cpu_per_sim_s(
    name: str, seeds: range, timesteps: list[float], extra: list[str]
) -> dict[float, float]:
    """Process CPU seconds per simulated second at each timestep, no probe attached."""
    loaded = {dt: load_scenario(name, _override(name, dt, extra)) for dt in timesteps}
    for dt in timesteps:
        run_episode(loaded[dt], 10_000)  # warm the caches, as a batch worker would
    cpu = dict.fromkeys(timesteps, 0.0)
    sim = dict.fromkeys(timesteps, 0.0)
    for seed in seeds:
        for dt in timesteps:
            t0 = time.process_time()
            r = run_episode(loaded[dt], seed)
            cpu[dt] += time.process_time() - t0
            sim[dt] += r.sim_time
    return {dt: cpu[dt] / sim[dt] for dt in timesteps}


def table(
    name: str, rows: dict[float, list[dict[str, Any]]], cpu: dict[float, float], hz: dict
) -> str:
    """Markdown: one row per figure (worst / p50), one column per timestep."""
    dts = list(rows)
    head = " | ".join(f"{dt * 1000:g} ms ({hz[dt]:g} Hz)" for dt in dts)
    out = [f"\n## {name}: {len(rows[dts[0]])} seeds", f"| figure | {head} | limit |"]
    out.append("|---" * (len(dts) + 2) + "|")

    def line(label: str, cells: list[str], limit: str = "") -> None:
        out.append(f"| {label} | " + " | ".join(cells) + f" | {limit} |")

    line("succeeded", [f"{sum(r['outcome'] == 'succeeded' for r in rows[dt])}" for dt in dts])
    for k in FIGURES:
        cells = []
        for dt in dts:
            v = np.array([r[k] for r in rows[dt]], float)
            cells.append(f"{v.max():.4g} / {np.median(v):.4g}")
        limit = LIMITS.get(k)
        line(f"{k} (worst / p50)", cells, "" if limit is None else f"{limit:g}")
    keys = metric_keys([r for dt in dts for r in rows[dt]])
    for k in keys:
        cells = []
        for dt in dts:
            v = np.array([r["metrics"][k] for r in rows[dt] if r["metrics"].get(k) is not None])
            cells.append(f"{v.max():.4g} / {np.median(v):.4g}" if len(v) else "-")
        line(f"metrics.{k} (worst / p50)", cells)
    if cpu:
        line("CPU s per simulated s", [f"{cpu[dt]:.4f}" for dt in dts])
        line("CPU real-time factor", [f"{1.0 / cpu[dt]:.1f}x" for dt in dts])
    return "\n".join(out)


def _parse(only: str) -> dict[str, tuple[int, int]]:
    runs = {}
    for item in only.split(","):
        name, spec = item.split("=")
        n, _, first = spec.partition("@")
        runs[name] = (int(n), int(first or 0))
    return runs


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--only",
        default="",
        help="NAME=N[@FIRST],... : these scenarios, N seeds from FIRST (default 0); default: "
        + ", ".join(f"{k}={n}@{f}" for k, (n, f) in STUDY.items()),
    )
    ap.add_argument("--timesteps", type=float, nargs="+", default=[0.002, 0.004, 0.005])
    ap.add_argument("--cpu-seeds", type=int, default=3, help="seeds timed without the probe")
    ap.add_argument("--set", action="append", default=[], help="override KEY=VALUE (all)")
    ap.add_argument("--json", help="write every figure to this file")
    args = ap.parse_args()
    runs = _parse(args.only) if args.only else STUDY
    out: dict[str, Any] = {"load_before": os.getloadavg(), "scenarios": {}}
    for name, (n, first) in runs.items():
        rows = study(name, range(first, first + n), args.timesteps, args.set)
        cpu_seeds = range(first, first + min(n, args.cpu_seeds))
        cpu = cpu_per_sim_s(name, cpu_seeds, args.timesteps, args.set) if args.cpu_seeds else {}
        hz = {dt: _control_hz(name, dt, args.set) for dt in args.timesteps}
        print(table(name, rows, cpu, hz), flush=True)
        print(f"load average {os.getloadavg()}", flush=True)
        out["scenarios"][name] = {
            str(dt): {"control_hz": hz[dt], "cpu_per_sim_s": cpu.get(dt), "rows": rows[dt]}
            for dt in args.timesteps
        }
    out["load_after"] = os.getloadavg()
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(out, fh, indent=1)


if __name__ == "__main__":
    main()
