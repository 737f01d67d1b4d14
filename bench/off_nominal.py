"""Off the happy path: every workload retries, rejects or recovers, and every stop holds.

Runs a matrix of off-nominal episodes on seeds of its own (none of them used while the flows
were built) and reports, per row: runs, aborts, hangs, outcomes (with the final state a failed
run names), every parcel's task-log outcome and reason, and the arm's rest speed over the hold
after every stop, measured every physics step on MuJoCo's state (not the log).

Rows:

* sorting with the pick area moved out to the edge of the reach (and the camera over it),
  with touching parcels (`gap_m=0`), with a single class;
* mobile_search with the block pushed against the approaching base, and with a grasp that
  misses (the pose seen once 5 cm off) next to the furniture;
* pick_place_vision and mobile_search with the target's colour swapped onto a distractor;
* every fault of every bundled scenario's fault matrix (`orchestrator faults S`).

Goal: 0 aborts and 0 hangs on the flow rows (each run `succeeded`, rejections allowed, or
`failed` in a final state that names why), every parcel sorted or rejected with a reason,
the arm below 0.01 rad/s over every hold, 0 undetected faults.

    python bench/off_nominal.py [--seeds 101 102 103] [--rows sorting_touching ...] [--json OUT]
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from orchestrator.batch.fault_matrix import MATRICES, expected
from orchestrator.engine.runner import WallTimeExceeded, run_episode
from orchestrator.language.load import load_scenario
from orchestrator.world.randomization import object_poses

SEEDS = (101, 102, 103)
"""The bench's own seeds (the flows were built and tuned on 0-20)."""
FAULT_SEED = 101
"""The seed every fault matrix runs on here (`orchestrator faults S` defaults to 0)."""
HANG_S = 900.0
"""Wall-clock limit of one episode: past it the run counts as a hang [s]."""
REST_RAD_S = 0.01
"""The arm at rest: every joint slower than this over the whole hold [rad/s]."""

_FAR = [
    "scene.parcels.area_center_xy=[0.64,-0.3]",
    "cameras.0.pos=[0.64,-0.3,0.75]",
    "cameras.0.look_at=[0.64,-0.3,0.2]",
]
_SWAP = [  # the red cube painted green, the green distractor painted red
    "scene.objects.0.rgba=[0.2,0.7,0.25,1.0]",
    "scene.objects.1.rgba=[0.85,0.15,0.15,1.0]",
]
FLOW_ROWS: dict[str, tuple[str, list[str], list[str]]] = {
    "sorting_out_of_reach": ("sorting", _FAR, []),
    "sorting_touching": ("sorting", ["scene.parcels.gap_m=0"], []),
    "sorting_single_class": ("sorting", ["scene.parcels.classes={A: [0.85,0.15,0.15,1.0]}"], []),
    "mobile_push": ("mobile_search", [], ["push_towards_robot"]),
    "mobile_missed_grasp": (
        "mobile_search",
        [],
        ["perception_offset:offset_m=[0.05,0.0,0.0],count=1@APPROACHING.LOOK"],
    ),
    "pick_place_vision_swapped": ("pick_place_vision", _SWAP, []),
    "mobile_search_swapped": ("mobile_search", _SWAP, []),
}
"""Row name -> (scenario, `--set` overrides, `--fault` specs); `push_towards_robot` is a push
of the block towards where the robot started, drawn per seed (`_push_towards_robot`)."""


def _push_towards_robot(scenario: str, sets: list[str], seed: int) -> str:
    """A push of the red block towards the room's centre (where the robot starts and whence
    it comes), 1.5 N for 0.3 s, 2 s into the base's closing in: it slides up to the chassis."""
    loaded = load_scenario(scenario, sets)
    pos = next(p for name, p, _ in object_poses(loaded.scenario, seed) if name == "cube")
    d = -np.asarray(pos[:2], float)
    fx, fy = (1.5 * d / float(np.linalg.norm(d))).round(3).tolist()
    return f"push:object=cube,force_n=[{fx},{fy},0],duration_ms=300@APPROACHING.CLOSE_IN+2.0"


class HoldProbe:
    """The arm's fastest joint over the holds after the controlled stop of an abort, every
    physics step, from the moment the stop declares the arm at rest: while the built-in safe
    stop holds it on its brakes (SAFE_STOP: `hold_max`), and while an `on_abort` response
    runs a `hold` skill on the motors (surgical's SAFE_HOLD.STOP: `response_hold_max`) — not
    while the response moves the arm on purpose (backs the tool out)."""

    def __init__(self) -> None:
        self.hold_max: float | None = None
        self.hold_steps = 0
        self.response_hold_max: float | None = None
        self.end_speed = 0.0

    def on_start(self, ctx, executor) -> None:
        self.executor = executor

    def on_tick(self, ctx, executor) -> None:
        pass

    def on_step(self, ctx) -> None:
        speed = float(np.max(np.abs(ctx.data.qvel[ctx.world.arm_dof])))
        self.end_speed = speed
        ex = self.executor
        if ex.stop is None or not ex.stop.at_rest:
            return
        if ex.final_state == "SAFE_STOP":
            self.hold_steps += 1
            self.hold_max = speed if self.hold_max is None else max(self.hold_max, speed)
        elif _running_skill(ex) == "hold":
            prev = self.response_hold_max
            self.response_hold_max = speed if prev is None else max(prev, speed)

    def on_end(self, ctx, executor, result) -> None:
        pass


def _running_skill(executor) -> str | None:
    """The name of the innermost running skill (None: none)."""
    activity = executor.region.activity if executor.region is not None else None
    while activity is not None and not hasattr(activity, "skill"):
        activity = getattr(activity, "activity", None)
    return None if activity is None else activity.skill.name


@dataclass
class Row:
    """One row of the report."""

    name: str
    kind: str
    runs: int = 0
    aborts: int = 0
    hangs: int = 0
    outcomes: Counter = field(default_factory=Counter)
    parcels: Counter = field(default_factory=Counter)
    reasons: Counter = field(default_factory=Counter)
    hold_max_rad_s: float = 0.0
    holds: int = 0
    response_hold_max_rad_s: float | None = None
    undetected: int = 0
    unexpected: list[str] = field(default_factory=list)
    episodes: list[dict[str, Any]] = field(default_factory=list)

    def to_dict(self) -> dict[str, Any]:
        return {
            "row": self.name,
            "kind": self.kind,
            "runs": self.runs,
            "aborts": self.aborts,
            "hangs": self.hangs,
            "outcomes": dict(self.outcomes),
            "parcels": dict(self.parcels),
            "reasons": dict(self.reasons),
            "holds": self.holds,
            "hold_max_rad_s": self.hold_max_rad_s,
            "response_hold_max_rad_s": self.response_hold_max_rad_s,
            "undetected": self.undetected,
            "unexpected": self.unexpected,
            "episodes": self.episodes,
        }


def _episode(scenario: str, sets: list[str], faults: list[str], seed: int) -> dict[str, Any]:
    loaded = load_scenario(scenario, sets, faults)
    probe = HoldProbe()
    t0 = time.perf_counter()
    try:
        result = run_episode(loaded, seed, [probe], max_wall_s=HANG_S)
        hung = False
    except WallTimeExceeded as exc:
        result, hung = exc.result, True
    r = result
    return {
        "seed": seed,
        "outcome": r.outcome,
        "final_state": r.final_state,
        "guard": (r.reason or {}).get("guard"),  # a time limit's reason names no guard
        "message": r.reason["message"] if r.reason else None,
        "hung": hung,
        "sim_time": r.sim_time,
        "wall_s": round(time.perf_counter() - t0, 2),
        "hold_max_rad_s": probe.hold_max,
        "hold_steps": probe.hold_steps,
        "response_hold_max_rad_s": probe.response_hold_max,
        "end_speed_rad_s": round(probe.end_speed, 6),
        "tasks": r.tasks,
        "faults": r.metrics.get("faults"),
        "abort_t": r.metrics.get("abort_t"),
        "stop_distance_mm": r.metrics.get("stop_distance_mm"),
        "stop_distance_min_mm": r.metrics.get("stop_distance_min_mm"),
        "stop_speed_m_s": r.metrics.get("stop_speed_m_s"),
        "details": [t["detail"] for t in r.transitions if "detail" in t],
    }


def _add(row: Row, e: dict[str, Any]) -> None:
    row.runs += 1
    row.episodes.append(e)
    row.hangs += e["hung"]
    row.aborts += e["outcome"] == "aborted"
    label = e["outcome"] if e["outcome"] == "succeeded" else f"{e['outcome']}:{e['final_state']}"
    row.outcomes[label] += 1
    for task in e["tasks"] or []:
        row.parcels[task["outcome"]] += 1
        if task.get("reason"):
            row.reasons[task["reason"].split(":")[0]] += 1
    if e["hold_max_rad_s"] is not None:
        row.holds += 1
        row.hold_max_rad_s = max(row.hold_max_rad_s, e["hold_max_rad_s"])
    if e["response_hold_max_rad_s"] is not None:
        prev = row.response_hold_max_rad_s
        row.response_hold_max_rad_s = max(prev or 0.0, e["response_hold_max_rad_s"])


def flow_row(name: str, seeds: list[int]) -> Row:
    scenario, sets, faults = FLOW_ROWS[name]
    row = Row(name, "flow")
    for seed in seeds:
        drawn = [
            _push_towards_robot(scenario, sets, seed) if f == "push_towards_robot" else f
            for f in faults
        ]
        e = _episode(scenario, sets, drawn, seed)
        _add(row, e)
        bad = (
            e["outcome"] == "aborted"
            or e["hung"]
            or (e["outcome"] == "failed" and e["final_state"] in (None, "FAILED"))
            or any(t["outcome"] not in ("sorted", "rejected") for t in e["tasks"] or [])
        )
        if bad:
            row.unexpected.append(f"seed {seed}: {e['outcome']} {e['final_state']} {e['message']}")
        _print_episode(name, e)
    return row


def fault_row(scenario: str, seed: int) -> Row:
    row = Row(f"faults {scenario}", "faults")
    for spec in MATRICES[scenario]:
        e = _episode(scenario, [], [spec.fault], seed)
        e["fault"], e["expect"], e["within_s"] = spec.fault, spec.expect, spec.within_s
        injected = e["faults"] or []
        e["detect_s"] = (
            None
            if e["abort_t"] is None or not injected
            else round(e["abort_t"] - injected[0]["t"], 4)
        )
        _add(row, e)
        ok = expected(spec, e["guard"], e["outcome"], e["detect_s"])
        row.undetected += e["guard"] is None and not ok
        if not ok:
            row.unexpected.append(
                f"{spec.fault}: expected {spec.expect} within {spec.within_s} s, got "
                f"{e['guard'] or e['outcome']} after {e['detect_s']} s"
            )
        _print_episode(row.name, e)
    return row


def _print_episode(name: str, e: dict[str, Any]) -> None:
    what = e.get("fault") or f"seed {e['seed']}"
    hold = "-" if e["hold_max_rad_s"] is None else f"{e['hold_max_rad_s']:.2e}"
    if e["response_hold_max_rad_s"] is not None:
        hold += f" (response {e['response_hold_max_rad_s']:.2e})"
    print(
        f"  {name} | {what} | {e['outcome']} {e['final_state']} {e['guard'] or ''} | "
        f"hold {hold} rad/s | {e['wall_s']} s",
        file=sys.stderr,
        flush=True,
    )


def report(rows: list[Row]) -> str:
    lines = [
        "| row | runs | aborts | hangs | outcomes | parcels (task log) | rejection reasons "
        "| stop holds: max speed [rad/s] | response holds [rad/s] | undetected |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        outcomes = ", ".join(f"{k} {v}" for k, v in sorted(r.outcomes.items()))
        parcels = ", ".join(f"{k} {v}" for k, v in sorted(r.parcels.items())) or "-"
        reasons = "; ".join(f"{k} {v}" for k, v in sorted(r.reasons.items())) or "-"
        hold = f"{r.holds}: {r.hold_max_rad_s:.1e}" if r.holds else "-"
        resp = "-" if r.response_hold_max_rad_s is None else f"{r.response_hold_max_rad_s:.1e}"
        lines.append(
            f"| {r.name} | {r.runs} | {r.aborts} | {r.hangs} | {outcomes} | {parcels} "
            f"| {reasons} | {hold} | {resp} | {r.undetected if r.kind == 'faults' else '-'} |"
        )
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=list(SEEDS))
    ap.add_argument("--fault-seed", type=int, default=FAULT_SEED)
    ap.add_argument("--rows", nargs="+", help="flow rows and/or `faults:SCENARIO` to run")
    ap.add_argument("--json", type=Path, help="write every episode here")
    args = ap.parse_args()
    wanted = args.rows or [*FLOW_ROWS, *(f"faults:{s}" for s in MATRICES)]
    rows: list[Row] = []
    t0 = time.perf_counter()
    for name in wanted:
        if name.startswith("faults:"):
            rows.append(fault_row(name.split(":", 1)[1], args.fault_seed))
        else:
            rows.append(flow_row(name, args.seeds))
    print(report(rows))
    flow = [r for r in rows if r.kind == "flow"]
    faults = [r for r in rows if r.kind == "faults"]
    holds = [r.hold_max_rad_s for r in rows if r.holds]
    print(
        f"\nflow rows: {sum(r.runs for r in flow)} runs, {sum(r.aborts for r in flow)} aborts, "
        f"{sum(r.hangs for r in flow)} hangs, "
        f"{sum(len(r.unexpected) for r in flow)} not accounted for; "
        f"fault rows: {sum(r.runs for r in faults)} runs, "
        f"{sum(r.undetected for r in faults)} undetected, "
        f"{sum(len(r.unexpected) for r in faults)} not as expected; "
        f"holds: {sum(r.holds for r in rows)}, max rest speed "
        f"{max(holds, default=0.0):.1e} rad/s (limit {REST_RAD_S}); "
        f"wall {time.perf_counter() - t0:.0f} s"
    )
    for r in rows:
        for u in r.unexpected:
            print(f"  {r.name}: {u}")
    if args.json:
        args.json.write_text(json.dumps([r.to_dict() for r in rows], indent=1))


if __name__ == "__main__":
    main()
