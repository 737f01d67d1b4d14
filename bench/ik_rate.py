"""The IK's rate against what it buys: path tracking, success and CPU per control rate.

The IK runs once per control tick (`physics.control_hz`, 100 Hz in every bundled scenario):
its dry runs at a move's start and its live solves after the path both step at that rate, and
the joint limiter and the controller's setpoint with them. This runs episodes at several
control rates and reports, per rate: the episodes that succeeded, the Cartesian tracking error
off the moves' paths (the measured TCP's distance from the path's curve, every tick a move
is on its path: median of the episodes' 95th percentiles, and the largest; not the lag along
it), the moves' final
TCP error (`tcp_error_mm`, the largest), the placement error where the scenario has one, the
largest wrist force, IK solves per simulated second, and CPU per physics step.

    python bench/ik_rate.py [--rates 25 50 100] [--only pick_place=5,sorting=1]
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

_SAMPLES = 400
"""Points a move's path is sampled at for the distance to it (a polyline)."""


def _distance(point: np.ndarray, line: np.ndarray) -> float:
    """Distance [m] from `point` to the polyline through the rows of `line` [m]."""
    a, b = line[:-1], line[1:]
    ab = b - a
    den = np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-18)
    s = np.clip(np.einsum("ij,ij->i", point - a, ab) / den, 0.0, 1.0)
    return float(np.min(np.linalg.norm(a + s[:, None] * ab - point, axis=1)))


def _parse_only(text: str) -> list[tuple[str, int]]:
    out = []
    for item in text.split(","):
        name, _, n = item.partition("=")
        out.append((name.strip(), int(n or 1)))
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rates", type=float, nargs="+", default=[25.0, 50.0, 100.0])
    parser.add_argument("--only", default="pick_place=5,sorting=1", help="NAME=N,...")
    args = parser.parse_args()

    from orchestrator.skills import ik, move

    from orchestrator.engine.runner import run_episode
    from orchestrator.language.load import load_scenario

    track: list[float] = []
    solves = [0]
    step, solve = move.Move.step, ik.IKSolver.reference_step

    polylines: dict[int, np.ndarray] = {}

    def tracked(self, ctx):  # the measured TCP's distance from the path while on it
        if self.reachable and ctx.clock - self.t0 < self.duration:
            line = polylines.get(id(self))
            if line is None:
                times = np.linspace(0.0, self.line.duration, _SAMPLES)
                line = polylines[id(self)] = np.array([self.line.sample_so3(t)[0] for t in times])
            track.append(_distance(ctx.tcp_pos, line))
        return step(self, ctx)

    def counted(self, *a):
        solves[0] += 1
        return solve(self, *a)

    move.Move.step = tracked  # type: ignore[method-assign]
    ik.IKSolver.reference_step = counted  # type: ignore[method-assign]
    print(
        "| scenario | control/IK rate | succeeded | off the path p95 (median) / max [mm] "
        "| final TCP error max [mm] | placement p50 / max [mm] | wrist force max [N] "
        "| IK solves per s | CPU us per physics step |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    for name, seeds in _parse_only(args.only):
        for rate in args.rates:
            loaded = load_scenario(name, [f"physics.control_hz={rate:g}"])
            dt = loaded.scenario.physics.timestep_s
            run_episode(loaded, 10_000)  # warm the caches
            ok, p95, worst, tcp, place, force, per_s, us = 0, [], 0.0, 0.0, [], 0.0, [], []
            for seed in range(seeds):
                track.clear()
                polylines.clear()
                solves[0] = 0
                cpu0 = time.process_time()
                r = run_episode(loaded, seed)
                cpu = time.process_time() - cpu0
                ok += r.outcome == "succeeded"
                if track:
                    p95.append(float(np.percentile(track, 95)) * 1e3)
                    worst = max(worst, max(track) * 1e3)
                m = r.metrics
                tcp = max(tcp, float(m.get("tcp_error_mm") or 0.0))
                for key in ("cube_on_target_xy_error_mm", "stacked_xy_error_mm"):
                    if m.get(key) is not None:
                        place.append(float(m[key]))
                force = max(force, float(m.get("max_wrist_force_n") or 0.0))
                per_s.append(solves[0] / r.sim_time)
                us.append(cpu / (r.sim_time / dt) * 1e6)
            placed = f"{statistics.median(place):.2f} / {max(place):.2f}" if place else "-"
            print(
                f"| {name} ({seeds}) | {rate:g} Hz | {ok}/{seeds} | "
                f"{statistics.median(p95):.2f} / {worst:.2f} | {tcp:.3f} | {placed} | "
                f"{force:.1f} | {statistics.median(per_s):.0f} | {statistics.median(us):.0f} |"
            )


if __name__ == "__main__":
    main()
