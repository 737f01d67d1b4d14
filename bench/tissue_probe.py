"""The tissue phantom's force-indentation curve, measured two ways.

1. **The law as MuJoCo applies it** (`orchestrator.world.tissue.indent`): the tip held at an
   indentation x, at rest and moving in / out at 1 cm/s, and MuJoCo's inverse dynamics gives
   the contact force of each tool geom (tip, shaft). Printed with the secant (f / x) and tangent
   (df / dx) stiffness and the damping (f(x, +v) - f(x, 0)) / v.
2. **In the closed loop**: the `contact` skill presses the phantom at a target force and holds;
   the tip's resting indentation (ground truth) is compared with the law's.

The phantom is the surgical scenario's at its nominal stiffness (no per-seed scale) unless
`--set` says otherwise.

    python bench/tissue_probe.py                       # the surgical phantom
    python bench/tissue_probe.py --set scene.phantom.stiffening.ratio=1   # a linear one
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np

from orchestrator.engine.runner import run_episode
from orchestrator.language.load import load_scenario
from orchestrator.world import World
from orchestrator.world.phantom import tissue_law
from orchestrator.world.tissue_probe import indent

DEPTHS_MM = [0.25, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 4.0]
SPEED = 0.01
"""Indentation speed of the damping columns [m/s]."""
NOMINAL = "scene.phantom.randomize.stiffness_scale=[1.0, 1.0]"

PRESS_MACHINE = """\
name: press
initial: ZERO
states:
  ZERO:
    skill: zero_sensor
    transitions: {zeroed: PRESS, out_of_tolerance: FAILED}
  PRESS:
    skill: contact
    with: {target_force_n: FORCE, approach_speed: 0.01, hold_s: 2.0, max_force_n: 20.0,
           surface_stiffness_n_per_m: 2000}
    transitions: {contacted: DONE, done: DONE, no_contact: FAILED, overforce: FAILED}
  DONE: {final: succeeded}
  FAILED: {final: failed}
"""
"""The probe's tip (20 cm tool, the arm at home) is 2 cm above the phantom placed below."""


def law_table(overrides: list[str]) -> None:
    scenario = load_scenario("surgical", [NOMINAL, *overrides]).scenario
    world = World.build(scenario, seed=0)
    law = tissue_law(scenario, 0)
    print(
        f"phantom: {law.stiffness:.0f} N/m at the surface, stiffening x{law.ratio:g} over "
        f"{law.depth_m * 1e3:g} mm, damping {law.damping:g} N s/m at the surface "
        f"(MuJoCo solimp {np.round(law.solimp(), 4).tolist()})\n"
    )
    print(
        "| indentation [mm] | tip force at rest [N] | shaft [N] | secant f/x [N/m] | "
        f"tangent df/dx [N/m] | in at {SPEED * 100:g} cm/s [N] | out [N] | damping [N s/m] |"
    )
    print("|---|---|---|---|---|---|---|---|")
    h = 1e-6
    for mm in DEPTHS_MM:
        x = mm * 1e-3
        rest = indent(world, x)
        tip = rest.get("probe_tip", 0.0)
        shaft = rest.get("probe_shaft", 0.0)
        loading = sum(indent(world, x, SPEED).values())
        unloading = sum(indent(world, x, -SPEED).values())
        tangent = (indent(world, x + h)["probe_tip"] - indent(world, x - h)["probe_tip"]) / (2 * h)
        damping = (loading - tip - shaft) / SPEED
        print(
            f"| {mm:g} | {tip:.3f} | {shaft:.2f} | {tip / x:.0f} | {tangent:.0f} | "
            f"{loading:.3f} | {unloading:.3f} | {damping:.1f} |"
        )
    print()


def closed_loop(overrides: list[str], forces: list[float]) -> None:
    base = load_scenario("surgical", [NOMINAL, *overrides]).scenario
    ph = base.scene.phantom
    assert ph is not None
    print("| target force [N] | resting force [N] | indentation [mm] | law's for that force [mm] |")
    print("|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        for force in forces:
            (Path(tmp) / "press.yaml").write_text(PRESS_MACHINE.replace("FORCE", str(force)))
            path = Path(tmp) / "press_scenario.yaml"
            path.write_text(
                "name: press\n"
                "tool: {name: probe, mass_kg: 0.25, length_m: 0.2}\n"
                "scene:\n"
                "  table: {center_xy: [0.3, 0.0], size_xy: [0.3, 0.3], height: 0.33}\n"
                f"  phantom: {{size: [0.1, 0.1, 0.04], xy: [0.307, 0.0], "
                f"stiffness_n_per_m: {ph.stiffness_n_per_m}, "
                f"stiffening: {{ratio: {ph.stiffening.ratio}, depth_m: {ph.stiffening.depth_m}}},"
                f" damping_n_s_per_m: {ph.damping_n_s_per_m}}}\n"
                "machine: press.yaml\n"
                "physics: {time_limit_s: 10}\n"
            )
            probe = _Rest()
            loaded = load_scenario(str(path))
            result = run_episode(loaded, 0, [probe])
            law = tissue_law(loaded.scenario, 0)
            depth = probe.surface - probe.tip_z
            lo, hi = 0.0, 0.05
            for _ in range(50):
                mid = 0.5 * (lo + hi)
                lo, hi = (mid, hi) if law.force(mid) < probe.force else (lo, mid)
            print(
                f"| {force:g} | {probe.force:.3f} | {depth * 1e3:.3f} | {lo * 1e3:.3f} |"
                + ("" if result.outcome == "succeeded" else f" ({result.outcome})")
            )


class _Rest:
    """The true contact force (noise-free sensor) and the tip height at the last tick."""

    def on_start(self, ctx, executor) -> None:
        self.force, self.tip_z, self.surface = 0.0, 0.0, 0.0

    def on_tick(self, ctx, executor) -> None:
        if executor.leaf == "PRESS":
            self.force = float(ctx.cell.wrist.true_force()[2])
            self.tip_z = float(ctx.tcp_pos[2])

    def on_end(self, ctx, executor, result) -> None:
        assert ctx.world.phantom is not None
        self.surface = float(ctx.world.phantom.surface_pos[2])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--set", action="append", default=[], help="scenario override KEY=VALUE")
    ap.add_argument(
        "--forces", default="1,2,3,4", help="closed-loop target forces [N], comma-separated"
    )
    args = ap.parse_args()
    law_table(args.set)
    closed_loop(args.set, [float(f) for f in args.forces.split(",") if f])


if __name__ == "__main__":
    main()
