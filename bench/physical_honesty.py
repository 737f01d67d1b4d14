"""Physical honesty: what the plant really did, instrumented at every physics step.

For each episode an observer's `on_step` reads MuJoCo's ground truth after every `mj_step`
(500 Hz) and keeps the worst of:

* joint speed |q̇| over the robot's limit (the URDF's velocity limits: the datasheet's,
  tests/test_robots.py), per joint;
* joint acceleration |Δq̇ / Δt| over the datasheet limits, per joint — also "outside contact
  events" (no contact of a robot geom other than the grasp in the last 10 ms);
* motor torque |τ| over the effort limit, and how many steps a motor sat at its limit
  (all, and outside contact events);
* how many steps any joint's acceleration was above its limit (also outside contact events);
* finger penetration into any object (the deepest finger contact) [mm];
* the fastest finger [m/s], and its ratio to the robot's own finger speed (the Franka Hand
  and the UR5's 2F-85-class gripper: 0.05 m/s per finger);
* the deepest contact of a free object with anything but the tissue phantom (the table, a bin,
  the floor, the belt, another object, a finger) [mm]: at rest (every free object and finger
  in the contact slower than `REST_SPEED_MPS` for `REST_S`: fingers closing on a still cube
  strike it, they do not rest on it), overall (impacts included) and after contact: a
  contact point's depth once it is found, while it still goes deeper. Contacts are found once
  a step: in the step a point is found in, a falling corner has crossed the surface by up to
  its speed x the step before anything pushes back, and in the next steps the contact pushes
  it back out of that overshoot (a parcel's corner found 4.07 mm deep at 2.08 m/s, 4.17 mm a
  step, then 3.01, 1.99, 1.00 mm while rising at 0.5 m/s): neither is the surface giving way.
  A point is the same as one of the last step's contacts of the same pair within
  `SAME_POINT_M` in the object's frame, so a box's far corner that lands while its first
  corner already touches is a new point, not the pair's continuation;
* the true wrist force (noise-free sensor, true hand + tool weight removed) [N];

and the run's own metrics. Prints one line per episode and a summary (worst, p50, p99) per
scenario; `--json PATH` writes every figure.

    python bench/physical_honesty.py                   # every bundled scenario (see --help)
    python bench/physical_honesty.py --only pick_place=30,surgical=5 \
        --set physics.realism.enabled=false
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from typing import Any

import mujoco
import numpy as np

from orchestrator.engine.runner import run_episode
from orchestrator.language.load import load_scenario

CONTACT_EVENT_S = 0.01
"""A step within this long of a contact of the arm with something (not the grasped object
held between the fingers) is inside a contact event [s]."""
SATURATED = 0.999
"""|τ| at or above this fraction of the effort limit counts as saturated."""
REST_SPEED_MPS = 0.01
"""A free object slower than this for `REST_S` counts as at rest [m/s] (not the bottom of a
bounce, where the speed passes through zero)."""
REST_S = 0.1
"""How long a free object must have been slow to be at rest [s]."""
SAME_POINT_M = 0.005
"""A contact within this distance of one of the last step's contacts of the same pair, both
in the object's body frame, is the same contact point [m] (a corner crosses at most its
depth's half between steps; the parcels' corners are centimetres apart)."""
RUNS = {
    "pick_place": 100,
    "pick_place_vision": 20,
    "mobile_search": 10,
    "sorting": 8,
    "sorting_conveyor": 4,
    "surgical": 20,
    "surgical_complication": 20,
    "stack": 10,
    "reach_random": 20,
    "pick_place_ur5": 20,
    "sorting_ur5": 5,
    "pick_place_so101": 20,
}
"""Every bundled scenario and its default number of seeds (0..N-1)."""
LIMITS = {
    "max_accel_ratio": 1.0,
    "accel_steps": 0,
    "finger_speed_ratio": 1.0,
    "penetration_rest_mm": 1.0,
    "penetration_after_contact_mm": 3.0,
}
"""What the datasheets allow of each figure (the summary marks a figure above its limit)."""


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
        self.object_vel = {h.geom_id: h.qvel_adr for h in w.objects.values()}
        self.finger_body = {g: int(m.geom_bodyid[g]) for g in self.fingers}
        self.moving_t = dict.fromkeys([*self.object_vel, *self.finger_body], 0.0)
        """Per object or finger geom, when it last moved faster than `REST_SPEED_MPS` [s]."""
        self.body_vel = np.zeros(6)
        self.tissue = m.geom(w.phantom.name).id if w.phantom is not None else -1
        self.finger_dof = [int(m.jnt_dofadr[m.joint(j).id]) for j in ctx.robot.finger_joints]
        self.geom_body = m.geom_bodyid
        self.last_contact_t = -math.inf
        self.v = np.zeros(len(self.dof))
        self.a = np.zeros(len(self.dof))
        self.a_free = np.zeros(len(self.dof))
        self.tau = np.zeros(len(self.dof))
        self.sat_steps = 0
        self.sat_free_steps = 0
        self.accel_steps = 0
        self.accel_free_steps = 0
        self.finger_speed = 0.0
        self.finger_speed_limit = float(ctx.robot.gripper_speed_mps)
        self.finger_scale = float(ctx.robot.finger_m_per_unit)
        """[m] of each side's opening per unit of a finger joint (a revolute jaw's radius / 2)."""
        """The robot's own finger speed [m/s] (the Franka Hand's and the UR5's gripper's 0.05)."""
        self.obj_pen_rest = 0.0
        self.obj_pen = 0.0
        self.obj_pen_after = 0.0
        self.points: dict[tuple[int, int], list[tuple[np.ndarray, float]]] = {}
        """Per object contact pair, its contact points of the last step in the object's body
        frame [m] and their depths [m] (a point not near one of them is new)."""
        self.pen_m = 0.0
        self.force_sq = 0.0
        self.where: dict[str, str] = {}
        self.steps = 0

    def on_tick(self, ctx, executor) -> None:
        pass

    def on_step(self, ctx) -> None:
        d, m = ctx.data, ctx.model
        self.steps += 1
        v = d.qvel[self.dof]
        a = np.abs(v - self.prev_v) / self.dt
        self.prev_v = v.copy()
        contact_event = False
        pen = 0.0
        qvel = d.qvel
        for g, adr in self.object_vel.items():
            if qvel[adr] ** 2 + qvel[adr + 1] ** 2 + qvel[adr + 2] ** 2 >= REST_SPEED_MPS**2:
                self.moving_t[g] = d.time
        for g, b in self.finger_body.items():  # the finger's world speed [rot; lin]
            mujoco.mj_objectVelocity(m, d, mujoco.mjtObj.mjOBJ_BODY, b, self.body_vel, 0)
            if float(self.body_vel[3:] @ self.body_vel[3:]) >= REST_SPEED_MPS**2:
                self.moving_t[g] = d.time
        points: dict[tuple[int, int], list[tuple[np.ndarray, float]]] = {}
        for i in range(d.ncon):
            c = d.contact[i]
            g1, g2 = int(c.geom1), int(c.geom2)
            if (g1 in self.objects or g2 in self.objects) and self.tissue not in (g1, g2):
                depth = -float(c.dist)
                pair = (min(g1, g2), max(g1, g2))
                b = self.geom_body[g1 if g1 in self.objects else g2]
                local = d.xmat[b].reshape(3, 3).T @ (c.pos - d.xpos[b])
                points.setdefault(pair, []).append((local, depth))
                self.obj_pen = max(self.obj_pen, depth)
                near = [
                    (float(np.sum((local - p) ** 2)), was)
                    for p, was in self.points.get(pair, ())
                    if float(np.sum((local - p) ** 2)) <= SAME_POINT_M**2
                ]
                sinking = bool(near) and depth > min(near)[1]
                if sinking and depth > self.obj_pen_after:
                    self.obj_pen_after, self.where["pen_after"] = depth, self.executor.leaf
                at_rest = all(
                    d.time - self.moving_t[g] >= REST_S for g in (g1, g2) if g in self.moving_t
                )
                if at_rest and depth > self.obj_pen_rest:
                    self.obj_pen_rest, self.where["pen_rest"] = depth, self.executor.leaf
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
        self.points = points
        if contact_event:
            self.last_contact_t = d.time
        free = d.time - self.last_contact_t > CONTACT_EVENT_S
        leaf = self.executor.leaf
        self._worst("v", np.abs(v) / self.vlim, leaf)
        ratio = a / self.alim
        self._worst("a", ratio, leaf)
        over = bool(ratio.max() > 1.0)
        self.accel_steps += over
        if free:
            self._worst("a_free", ratio, leaf)
            self.accel_free_steps += over
        for dof in self.finger_dof:
            speed = abs(float(qvel[dof])) * self.finger_scale
            if speed > self.finger_speed:
                self.finger_speed, self.where["finger"] = speed, leaf
        tau = np.abs(d.actuator_force[self.act]) / self.tlim
        self._worst("tau", tau, leaf)
        if tau.max() >= SATURATED:
            self.sat_steps += 1
            self.sat_free_steps += free
        if pen > self.pen_m:
            self.pen_m, self.where["pen"] = pen, leaf
        f = ctx.cell.wrist.true_norm_sq()
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
            "accel_steps": self.accel_steps,
            "accel_steps_outside_contact": self.accel_free_steps,
            "finger_speed_mps": round(self.finger_speed, 5),
            "finger_speed_ratio": round(self.finger_speed / self.finger_speed_limit, 4),
            "penetration_rest_mm": round(self.obj_pen_rest * 1000, 4),
            "penetration_mm": round(self.obj_pen * 1000, 4),
            "penetration_after_contact_mm": round(self.obj_pen_after * 1000, 4),
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
            f" [{row['accel_steps']} steps over] tau {row['max_torque_ratio']:.2f}"
            f" sat {row['saturated_steps']}/{row['saturated_steps_outside_contact']}"
            f" finger {row['finger_speed_mps']:.4f}m/s pen {row['finger_penetration_mm']:.3f}"
            f" rest {row['penetration_rest_mm']:.3f} any {row['penetration_mm']:.3f}"
            f" ({row['penetration_after_contact_mm']:.3f})mm"
            f" F {row['max_wrist_force_n']:.2f}N [{time.perf_counter() - t0:.1f}s]",
            file=sys.stderr,
            flush=True,
        )
    return rows


FIGURES = [
    "max_speed_ratio",
    "max_accel_ratio",
    "max_accel_ratio_outside_contact",
    "accel_steps",
    "accel_steps_outside_contact",
    "max_torque_ratio",
    "saturated_steps",
    "saturated_steps_outside_contact",
    "finger_speed_mps",
    "finger_speed_ratio",
    "finger_penetration_mm",
    "penetration_rest_mm",
    "penetration_mm",
    "penetration_after_contact_mm",
    "max_wrist_force_n",
]
"""The probe's figures of a row, in the order the tables print them."""


def metric_keys(rows: list[dict[str, Any]]) -> list[str]:
    """The numeric run metrics of `rows` (not flags, not the tick count or abort time)."""
    return sorted(
        {
            k
            for r in rows
            for k, v in r["metrics"].items()
            if isinstance(v, int | float) and not isinstance(v, bool)
        }
        - {"control_ticks", "abort_t"}
    )


def summarize(rows: list[dict[str, Any]]) -> None:
    name = rows[0]["scenario"]
    ok = sum(r["outcome"] == "succeeded" for r in rows)
    aborted = sum(r["outcome"] == "aborted" for r in rows)
    print(f"\n## {name}: {len(rows)} seeds, {ok} succeeded, {aborted} aborted")
    print("| figure | worst | p99 | p50 | limit |\n|---|---|---|---|---|")
    for k in FIGURES:
        vals = np.array([r[k] for r in rows], float)
        limit = LIMITS.get(k)
        over = limit is not None and vals.max() > limit * (1.0 + 1e-9)
        mark = "" if limit is None else f"{limit:g}" + (" **over**" if over else "")
        print(
            f"| {k} | {vals.max():.4g} | {np.percentile(vals, 99):.4g} | {np.median(vals):.4g}"
            f" | {mark} |"
        )
    for k in metric_keys(rows):
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
    ap.add_argument(
        "--only",
        default="",
        help="NAME=N,... : these scenarios, N seeds each (0..N-1); default: "
        + ", ".join(f"{k}={v}" for k, v in RUNS.items()),
    )
    ap.add_argument("--first-seed", type=int, default=0, help="seeds start here")
    ap.add_argument("--set", action="append", default=[], help="override KEY=VALUE (all)")
    ap.add_argument("--json", help="write every figure to this file")
    args = ap.parse_args()
    runs = RUNS
    if args.only:
        runs = {k: int(v) for k, v in (item.split("=") for item in args.only.split(","))}
    out: list[dict[str, Any]] = []
    for name, n in runs.items():
        if n > 0:
            rows = run(name, range(args.first_seed, args.first_seed + n), args.set)
            summarize(rows)
            out += rows
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(out, fh, indent=1)


if __name__ == "__main__":
    main()
