"""Where a pick_place cycle's time goes: per state, and per motion its path time (how much of
it is the guarded slow stretch), the uniform stretch the joints still needed, and the time it
took to converge after its path ended. Simulated time (the host's load does not change it).

    python bench/pick_cycle.py                      # pick_place, seeds 0-9
    python bench/pick_cycle.py pick_place_ur5 --seeds 20
"""

from __future__ import annotations

import argparse
import statistics
from collections import defaultdict

import numpy as np
from orchestrator.skills import move as move_skill
from orchestrator.skills.blended_path import BlendedPath

from orchestrator.engine.runner import run_episode
from orchestrator.language.load import load_scenario


def _slow_time(path: object, speed: float) -> float:
    """Time the path's timing law spends at or under `speed` + 1 % while moving [s]."""
    if not isinstance(path, BlendedPath):
        return 0.0
    t, v = path._t, path._v
    slow = (v[1:] <= speed * 1.01) & (v[:-1] <= speed * 1.01) & (v[1:] + v[:-1] > 0.0)
    return float(np.sum(np.diff(t)[slow]))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenario", nargs="?", default="pick_place")
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--set", action="append", default=[], help="KEY=VALUE (scenario override)")
    args = ap.parse_args()
    moves: list[dict] = []
    start, stop = move_skill.Move.start, move_skill.Move.stop

    def started(self, ctx):
        start(self, ctx)
        p = self.params
        slow = _slow_time(self.line, p.guarded_speed_mps) * self.stretch if p.guarded_from_m else 0
        self._bench = {
            "t0": ctx.clock,
            "path": self.duration,
            "stretch": self.stretch,
            "slow": slow,
        }

    def stopped(self, ctx):
        b = self._bench
        b["after_path"] = ctx.clock - b["t0"] - b["path"]
        moves.append(b)
        stop(self, ctx)

    move_skill.Move.start, move_skill.Move.stop = started, stopped
    loaded = load_scenario(args.scenario, args.set)
    per_state: dict[str, list[float]] = defaultdict(list)
    per_move: dict[str, list[dict]] = defaultdict(list)
    cycles = []
    for seed in range(args.seeds):
        moves.clear()
        r = run_episode(loaded, seed)
        cycles.append(r.metrics.get("cycle_time") or float("nan"))
        prev, states = 0.0, []
        for tr in r.transitions:
            per_state[tr["from"]].append(tr["t"] - prev)
            states.append(tr["from"])
            prev = tr["t"]
        motion_states = [s for s in states if s.split(".")[-1] in _MOTIONS]
        for name, b in zip(motion_states, moves, strict=False):
            per_move[name].append(b)
        print(f"seed {seed}: {r.outcome}, cycle {r.metrics.get('cycle_time')} s", flush=True)
    print(f"\n{args.scenario}, {args.seeds} seeds: cycle p50 {statistics.median(cycles):.3f} s")
    print(f"{'state':28s} {'p50 [s]':>8s}")
    for name, ts in per_state.items():
        print(f"{name:28s} {statistics.median(ts):8.3f}")
    print(f"\n{'motion':28s} {'path':>6s} {'slow':>6s} {'stretch':>8s} {'after':>6s}  (p50 [s])")
    for name, bs in per_move.items():
        med = {
            k: statistics.median(b[k] for b in bs)
            for k in ("path", "slow", "stretch", "after_path")
        }
        print(
            f"{name:28s} {med['path']:6.3f} {med['slow']:6.3f} {med['stretch']:8.2f} "
            f"{med['after_path']:6.3f}"
        )


_MOTIONS = {"APPROACH", "LIFT", "TRANSPORT", "RETREAT", "BACK_OFF"}

if __name__ == "__main__":
    main()
