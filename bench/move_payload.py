"""Do `move`'s default parameters settle while the gripper carries a payload?

A flow picks the cube (the bundled grasp machine), then carries it with three `move`
states that set nothing but `target` and `offset` — every other parameter at its default:
CARRY (to 10 cm above the pad), LOWER (to 3 cm above it) and, after opening, RETREAT.
The cube's mass is swept over 0.1–0.5 kg; each mass runs several seeds. Per move it reports
the outcome, the time from the end of the line to `reached` (the settling time) and the
largest remaining TCP error when the move ended. With `--set` any default can be tried
instead (`--set tolerance_m=0.001`).

    python bench/move_payload.py [--seeds 5] [--masses 0.1 0.25 0.5] [--set KEY=VALUE ...]
"""

from __future__ import annotations

import argparse
import math
import statistics
import tempfile
from pathlib import Path

from orchestrator.engine.runner import run_episode
from orchestrator.language.load import load_scenario

MACHINE = """\
name: carry_defaults
initial: PICK
blackboard: {{object: cube, object_pose: {{type: pose}}}}
guards: [joint_limits]
states:
  PICK:
    initial: SEARCH
    states:
      SEARCH:
        skill: search
        with: {{object: $object, into: object_pose}}
        transitions: {{found: GRASP, not_found: LOST}}
      GRASP:
        machine: grasp
        transitions: {{grasped: PICKED, missed: LOST, unreachable: LOST}}
      PICKED: {{final: picked}}
      LOST: {{final: lost}}
    transitions: {{picked: CARRY, lost: FAILED}}
  CARRY:
    skill: move
    with: {{target: pad, offset: [0, 0, 0.10]{extra}}}
    transitions: {{reached: LOWER, unreachable: FAILED, timeout: FAILED}}
  LOWER:
    skill: move
    with: {{target: pad, offset: [0, 0, 0.03]{extra}}}
    transitions: {{reached: OPEN, unreachable: FAILED, timeout: FAILED}}
  OPEN:
    skill: release
    transitions: {{released: RETREAT, timeout: FAILED}}
  RETREAT:
    skill: move
    with: {{target: pad, offset: [0, 0, 0.10]{extra}}}
    transitions: {{reached: DONE, unreachable: FAILED, timeout: FAILED}}
  DONE: {{final: succeeded}}
  FAILED: {{final: failed}}
"""

SCENARIO = """\
name: carry_{mass}
machine: m.yaml
scene:
  objects:
    - {{name: cube, size: [0.05, 0.05, 0.05], mass: {mass}, xy: [0.5, -0.12],
       randomize: {{x: [-0.05, 0.05], y: [-0.05, 0.05], yaw_deg: [-30, 30]}}}}
  markers:
    - {{name: pad, xy: [0.5, 0.2]}}
success:
  on_pad: {{kind: object_at, object: cube, target: pad, xy_tol_m: 0.01}}
physics: {{time_limit_s: 20}}
"""

MOVES = ("CARRY", "LOWER", "RETREAT")


class MoveProbe:
    """Records, per `move` state, the settling time after its line and its final error."""

    def __init__(self) -> None:
        self.rows: dict[str, dict[str, float]] = {}
        self._skill = None
        self._state = ""

    def on_start(self, ctx, executor) -> None:
        pass

    def on_tick(self, ctx, executor) -> None:
        from orchestrator.skills.move import Move

        activity = executor.region.activity if executor.region is not None else None
        skill = getattr(activity, "skill", None)
        if isinstance(skill, Move) and executor.leaf in MOVES:
            pos_err, ang_err = skill.tcp_error(ctx)
            self._skill, self._state = skill, executor.leaf
            self.rows[executor.leaf] = {
                "settle_s": max(0.0, ctx.t - skill.t0 - skill.line.duration),
                "pos_err_mm": pos_err * 1000.0,
                "ang_err_deg": math.degrees(ang_err),
            }

    def on_end(self, ctx, executor, result) -> None:
        pass


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", type=int, default=5)
    parser.add_argument("--masses", type=float, nargs="+", default=[0.1, 0.25, 0.5])
    parser.add_argument("--set", dest="sets", action="append", default=[])
    args = parser.parse_args()
    extra = "".join(f", {kv.split('=', 1)[0]}: {kv.split('=', 1)[1]}" for kv in args.sets)
    print(f"move parameters: defaults{' + ' + ', '.join(args.sets) if args.sets else ''}")
    print(f"{'mass':>5} {'move':8} {'reached':>8} {'settle med':>10} {'settle max':>10} "
          f"{'err max [mm]':>12} {'[deg]':>6}  episodes")  # fmt: skip
    with tempfile.TemporaryDirectory() as tmp:
        (Path(tmp) / "m.yaml").write_text(MACHINE.format(extra=extra))
        for mass in args.masses:
            path = Path(tmp) / f"s{mass}.yaml"
            path.write_text(SCENARIO.format(mass=mass))
            loaded = load_scenario(str(path))
            per_move: dict[str, list[tuple[str, dict[str, float]]]] = {m: [] for m in MOVES}
            outcomes = []
            for seed in range(args.seeds):
                probe = MoveProbe()
                result = run_episode(loaded, seed, [probe])
                outcomes.append(result.outcome)
                triggers = {tr["from"]: tr for tr in result.transitions}
                for m in MOVES:
                    if m in probe.rows and m in triggers:
                        per_move[m].append((triggers[m]["trigger"], probe.rows[m]))
                        if triggers[m]["trigger"] != "reached":
                            print(f"      seed {seed} {m}: {triggers[m].get('detail')}")
            for m in MOVES:
                rows = per_move[m]
                if not rows:
                    print(f"{mass:5.2f} {m:8} {'-':>8}")
                    continue
                reached = sum(1 for trig, _ in rows if trig == "reached")
                settle = [r["settle_s"] for trig, r in rows if trig == "reached"] or [math.nan]
                print(
                    f"{mass:5.2f} {m:8} {reached:>4}/{len(rows):<3} "
                    f"{statistics.median(settle):10.3f} {max(settle):10.3f} "
                    f"{max(r['pos_err_mm'] for _, r in rows):12.2f} "
                    f"{max(r['ang_err_deg'] for _, r in rows):6.2f}  " + ", ".join(outcomes)
                )


if __name__ == "__main__":
    main()
