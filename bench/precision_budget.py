"""Where the surgical trace's cross-track error comes from: its budget, every physics step.

The true cross-track error (the tool tip's lateral distance from the incision mapped through
the phantom's true pose) is the sum of four signed parts, measured along the same lateral
direction (the true surface normal crossed with the direction of the line):

* registration: the registered line (what the skill was told) from the true line;
* setpoint: the impedance setpoint from the registered line (the skill's own shaping);
* controller: the tip as the controller's own pinocchio model puts it (forward kinematics of
  the encoder readings) from the setpoint — the steady-state error of the impedance under
  joint friction, contact friction and model mismatch;
* calibration: the true tip (MuJoCo's site) from where the controller's model puts it — the
  tool-tip calibration and the encoder quantization.

IK is not in the loop while tracing (the contact skill commands the Cartesian impedance), so
it contributes nothing; NAVIGATE's IK error is taken up by the contact skill's approach.

    python bench/precision_budget.py --seeds 1000-1019 [--scenario surgical] [--set K=V ...]

Prints one row per seed (mean and worst of each part [mm]) and a summary.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from typing import Any

import numpy as np
import pinocchio as pin

from orchestrator.engine.runner import run_episode
from orchestrator.language.load import load_scenario
from orchestrator.world.path import PlannedPath

PARTS = ("registration", "setpoint", "controller", "calibration", "total")


def _signed(path: PlannedPath, side: np.ndarray, point: np.ndarray) -> float:
    """Signed lateral distance [m] of `point` from `path` along `side` (a unit vector)."""
    p = np.asarray(point, float)
    if path.normal is not None:
        p = p - float(p @ path.normal) * path.normal
    best, sign = math.inf, 0.0
    for a, b in zip(path.points[:-1], path.points[1:], strict=True):
        seg = b - a
        u = min(max(float((p - a) @ seg) / float(seg @ seg), 0.0), 1.0)
        err = p - (a + u * seg)
        d = float(np.linalg.norm(err))
        if d < best:
            best, sign = d, float(err @ side)
    return sign


class BudgetProbe:
    """Signed cross-track parts at every physics step of the trace."""

    def on_start(self, ctx, executor) -> None:
        self.ctx = ctx
        self.model = ctx.controller.model
        self.data = self.model.createData()
        self.tcp_id = ctx.controller.tcp_id
        self.base = np.asarray(ctx.scenario.robot.base_pos, float)
        self.tip = ctx.data.site_xpos[ctx.world.tcp_site]
        self.spec = None
        self.rows: list[tuple[float, ...]] = []

    def on_tick(self, ctx, executor) -> None:
        pass

    def on_step(self, ctx) -> None:
        spec = ctx.trace
        if spec is None:
            return
        if spec is not self.spec:
            self.spec = spec
            ph = ctx.world.phantom
            true_pts = spec.local_points @ ph.rotation.T + ph.surface_pos
            normal = ph.rotation[:, 2]
            self.true = PlannedPath(true_pts, normal)
            pos, rot = spec.frame
            self.registered = PlannedPath(spec.local_points @ rot.T + pos, normal)
            d = true_pts[-1] - true_pts[0]
            self.side = np.cross(normal, d / np.linalg.norm(d))
        q, _ = ctx.cell.encoders.read()
        pin.framesForwardKinematics(self.model, self.data, q)
        fk = self.data.oMf[self.tcp_id].translation + self.base
        ctrl = ctx.controller
        setpoint = ctrl.pos_d + self.base
        reg = _signed(self.true, self.side, self.registered.point_at(self.true.progress(self.tip)))
        sp = _signed(self.registered, self.side, setpoint)
        controller = float((fk - setpoint) @ self.side)
        calibration = float((self.tip - fk) @ self.side)
        total = _signed(self.true, self.side, self.tip)
        self.rows.append((reg, sp, controller, calibration, total))

    def on_end(self, ctx, executor, result) -> None:
        pass

    def figures(self) -> dict[str, Any]:
        arr = np.array(self.rows) * 1000.0
        out: dict[str, Any] = {"steps": len(arr)}
        for i, part in enumerate(PARTS):
            out[f"{part}_mean_mm"] = round(float(arr[:, i].mean()), 4)
            out[f"{part}_max_mm"] = round(float(np.abs(arr[:, i]).max()), 4)
        return out


def _seeds(text: str) -> list[int]:
    if "-" in text:
        a, b = text.split("-")
        return list(range(int(a), int(b) + 1))
    return [int(s) for s in text.split(",")]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenario", default="surgical")
    ap.add_argument("--seeds", default="1000-1004", help="e.g. 1000-1019 or 3,5,8")
    ap.add_argument("--set", action="append", default=[], help="override KEY=VALUE")
    ap.add_argument("--json", help="write every figure to this file")
    args = ap.parse_args()
    loaded = load_scenario(args.scenario, args.set or None)
    rows = []
    print(
        "seed outcome  " + " ".join(f"{p[:5]:>6s}/max" for p in PARTS) + "  true max/rms [mm]",
        file=sys.stderr,
    )
    for seed in _seeds(args.seeds):
        probe = BudgetProbe()
        t0 = time.perf_counter()
        result = run_episode(loaded, seed, [probe])
        fig = probe.figures()
        m = result.metrics
        row = {"seed": seed, "outcome": result.outcome, **fig, "metrics": m}
        rows.append(row)
        parts = " ".join(f"{fig[p + '_mean_mm']:+.3f}/{fig[p + '_max_mm']:.3f}" for p in PARTS)
        print(
            f"{seed:5d} {result.outcome:9s} {parts}  {m.get('true_cross_track_max_mm')}"
            f"/{m.get('true_cross_track_rms_mm')} F {m.get('true_force_rms_error_n')}"
            f" [{time.perf_counter() - t0:.1f}s]",
            file=sys.stderr,
            flush=True,
        )
    print("\n| part | mean of |mean| [mm] | worst |mean| | worst |max| |\n|---|---|---|---|")
    for p in PARTS:
        means = np.abs([r[p + "_mean_mm"] for r in rows])
        maxes = [r[p + "_max_mm"] for r in rows]
        print(f"| {p} | {means.mean():.4f} | {means.max():.4f} | {max(maxes):.4f} |")
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(rows, fh, indent=1)


if __name__ == "__main__":
    main()
