"""Physical honesty: what the plant really did, instrumented at every physics step.

For each episode an observer's `on_step` reads MuJoCo's ground truth after every `mj_step`
(500 Hz) and keeps the worst of:

* joint speed |q̇| over the Panda's limit (the URDF's velocity limits), per joint;
* joint acceleration |Δq̇ / Δt| over the datasheet limits, per joint — also "outside contact
  events" (no contact of a robot geom other than the grasp in the last 10 ms);
* motor torque |τ| over the effort limit, and how many steps a motor sat at its limit
  (all, and outside contact events);
* finger penetration into any object (the deepest finger contact) [mm];
* the true wrist force (noise-free sensor, true hand + tool weight removed) [N];

and the run's own metrics. Prints one line per episode and a summary (worst, p50, p99) per
scenario; `--json PATH` writes every figure.

    python bench/physical_honesty.py                      # 100 pick_place + 20 + 20 surgical
    python bench/physical_honesty.py --pick 30 --surgical 5 --set physics.realism.enabled=false
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from typing import Any

import numpy as np

from orchestrator.engine.runner import run_episode
from orchestrator.language.load import load_scenario

CONTACT_EVENT_S = 0.01
"""A step within this long of a contact of the arm with something (not the grasped object
held between the fingers) is inside a contact event [s]."""
SATURATED = 0.999
"""|τ| at or above this fraction of the effort limit counts as saturated."""


class StepProbe:
    """Worst figures over every physics step of one episode (ground truth)."""

    def on_start(self, ctx, executor) -> None:
        w, m = ctx.world, ctx.model
        self.ctx, self.executor = ctx, executor
        self.dof = w.arm_dof
        self.vlim = ctx.robot.joint_velocity_limits()
        self.alim = np.asarray(ctx.robot.acceleration_limits, float)
        self.tlim = w.arm_effort_limit
        self.act = w.arm_act
        self.dt = ctx.dt_physics
        self.prev_v = ctx.data.qvel[self.dof].copy()
        self.fingers = w.finger_geoms
        self.robot = w.robot_geoms
        self.objects = {h.geom_id for h in w.objects.values()}
        self.geom_body = m.geom_bodyid
        self.last_contact_t = -math.inf
        self.v = np.zeros(len(self.dof))
        self.a = np.zeros(len(self.dof))
        self.a_free = np.zeros(len(self.dof))
        self.tau = np.zeros(len(self.dof))
        self.sat_steps = 0
        self.sat_free_steps = 0
        self.pen_m = 0.0
        self.force_sq = 0.0
        self.where: dict[str, str] = {}
        self.steps = 0

    def on_tick(self, ctx, executor) -> None:
        pass

    def on_step(self, ctx) -> None:
        d = ctx.data
        self.steps += 1
        v = d.qvel[self.dof]
        a = np.abs(v - self.prev_v) / self.dt
        self.prev_v = v.copy()
        contact_event = False
        pen = 0.0
        for i in range(d.ncon):
            c = d.contact[i]
            g1, g2 = int(c.geom1), int(c.geom2)
            r1, r2 = g1 in self.robot, g2 in self.robot
            if not (r1 or r2):
                continue
            grip = (g1 in self.fingers and g2 in self.objects) or (
                g2 in self.fingers and g1 in self.objects
            )
            if grip:
                pen = max(pen, -float(c.dist))
            else:
                contact_event = True
        if contact_event:
            self.last_contact_t = d.time
        free = d.time - self.last_contact_t > CONTACT_EVENT_S
        leaf = self.executor.leaf
        self._worst("v", np.abs(v) / self.vlim, leaf)
        self._worst("a", a / self.alim, leaf)
        if free:
            self._worst("a_free", a / self.alim, leaf)
        tau = np.abs(d.actuator_force[self.act]) / self.tlim
        self._worst("tau", tau, leaf)
        if tau.max() >= SATURATED:
            self.sat_steps += 1
            self.sat_free_steps += free
        if pen > self.pen_m:
            self.pen_m, self.where["pen"] = pen, leaf
        f = ctx.true_wrist_force_norm_sq()
        if f > self.force_sq:
            self.force_sq, self.where["force"] = f, leaf

    def _worst(self, key: str, ratio: np.ndarray, leaf: str) -> None:
        arr = getattr(self, key)
        if ratio.max() > arr.max():
            self.where[key] = f"{leaf} (joint {int(ratio.argmax()) + 1})"
        np.maximum(arr, ratio, out=arr)

    def on_end(self, ctx, executor, result) -> None:
        pass

    def figures(self) -> dict[str, Any]:
        return {
            "max_speed_ratio": round(float(self.v.max()), 4),
            "max_accel_ratio": round(float(self.a.max()), 4),
            "max_accel_ratio_outside_contact": round(float(self.a_free.max()), 4),
            "max_torque_ratio": round(float(self.tau.max()), 4),
            "saturated_steps": self.sat_steps,
            "saturated_steps_outside_contact": self.sat_free_steps,
            "finger_penetration_mm": round(self.pen_m * 1000, 4),
            "max_wrist_force_n": round(math.sqrt(self.force_sq), 4),
            "steps": self.steps,
            "where": self.where,
        }


def run(name: str, seeds: range, overrides: list[str]) -> list[dict[str, Any]]:
    loaded = load_scenario(name, overrides or None)
    rows = []
    for seed in seeds:
        probe = StepProbe()
        t0 = time.perf_counter()
        result = run_episode(loaded, seed, [probe])
        row = {"scenario": name, "seed": seed, "outcome": result.outcome, **probe.figures()}
        row["metrics"] = result.metrics
        row["reason"] = result.reason
        rows.append(row)
        print(
            f"{name:22s} {seed:4d} {result.outcome:9s} v {row['max_speed_ratio']:.2f}"
            f" a {row['max_accel_ratio']:.2f} (free {row['max_accel_ratio_outside_contact']:.2f})"
            f" tau {row['max_torque_ratio']:.2f} sat {row['saturated_steps']}"
            f"/{row['saturated_steps_outside_contact']} pen {row['finger_penetration_mm']:.3f}mm"
            f" F {row['max_wrist_force_n']:.2f}N [{time.perf_counter() - t0:.1f}s]",
            file=sys.stderr,
            flush=True,
        )
    return rows


def summarize(rows: list[dict[str, Any]]) -> None:
    name = rows[0]["scenario"]
    ok = sum(r["outcome"] == "succeeded" for r in rows)
    aborted = sum(r["outcome"] == "aborted" for r in rows)
    print(f"\n## {name}: {len(rows)} seeds, {ok} succeeded, {aborted} aborted")
    print("| figure | worst | p99 | p50 |\n|---|---|---|---|")
    keys = [
        "max_speed_ratio",
        "max_accel_ratio",
        "max_accel_ratio_outside_contact",
        "max_torque_ratio",
        "saturated_steps",
        "saturated_steps_outside_contact",
        "finger_penetration_mm",
        "max_wrist_force_n",
    ]
    metric_keys = sorted(
        {k for r in rows for k, v in r["metrics"].items() if isinstance(v, int | float)}
        - {"control_ticks", "abort_t"}
    )
    for k in keys:
        vals = np.array([r[k] for r in rows], float)
        print(f"| {k} | {vals.max():.4g} | {np.percentile(vals, 99):.4g} | {np.median(vals):.4g} |")
    for k in metric_keys:
        vals = np.array([r["metrics"][k] for r in rows if r["metrics"].get(k) is not None], float)
        if len(vals):
            print(
                f"| metrics.{k} | {vals.max():.4g} | {np.percentile(vals, 99):.4g}"
                f" | {np.median(vals):.4g} |"
            )
    worst = max(rows, key=lambda r: r["max_accel_ratio_outside_contact"])
    where = worst["where"].get("a_free")
    print(f"worst acceleration outside contact: seed {worst['seed']} at {where}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--pick", type=int, default=100, help="pick_place seeds (0..N-1)")
    ap.add_argument("--surgical", type=int, default=20, help="surgical seeds (0..N-1)")
    ap.add_argument("--complication", type=int, default=20, help="surgical_complication seeds")
    ap.add_argument("--set", action="append", default=[], help="override KEY=VALUE (all)")
    ap.add_argument("--json", help="write every figure to this file")
    args = ap.parse_args()
    out: list[dict[str, Any]] = []
    for name, n in (
        ("pick_place", args.pick),
        ("surgical", args.surgical),
        ("surgical_complication", args.complication),
    ):
        if n > 0:
            rows = run(name, range(n), args.set)
            summarize(rows)
            out += rows
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(out, fh, indent=1)


if __name__ == "__main__":
    main()
