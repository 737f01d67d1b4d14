"""`move_joints` keeps every joint within its datasheet limits, whatever it is asked for.

Its `max_speed` and `max_accel` are the furthest-moving joint's; the schema allows up to
2.5 rad/s and 20 rad/s^2, above what several Panda joints can do (joint 2: 2.175 rad/s,
7.5 rad/s^2). The profile is lowered to the share of the limits the IK's commands keep, and the
arm is measured at every physics step.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from orchestrator.robots import Panda

from orchestrator.engine.runner import run_episode
from orchestrator.language.load import load_scenario

from .test_physical_honesty import StepProbe


class Probe(StepProbe):
    """The arm's worst step, and the run's log."""

    def on_end(self, ctx, executor, result) -> None:
        self.messages = [e.message for e in ctx.events]


MACHINE = """\
name: swing
initial: SWING
states:
  SWING:
    skill: move_joints
    with: {{to: {goal}, max_speed: 2.5, max_accel: 20.0}}
    transitions: {{reached: DONE, timeout: FAILED}}
  DONE: {{final: succeeded}}
  FAILED: {{final: failed}}
"""
SCENARIO = """\
name: swing
machine: swing.yaml
scene:
  table: {center_xy: [0.55, 0.0], size_xy: [0.7, 0.9], height: 0.2}
guards:
  joint_limits: {}
  joint_velocity: {}
physics: {time_limit_s: 6}
"""


def test_a_fast_joint_move_is_slowed_to_the_joints_limits(tmp_path: Path):
    goal = np.array(Panda.home, float)
    goal[1] += 0.9  # joint 2 moves furthest: its limits are the Panda's lowest
    goal[3] += 0.4
    (tmp_path / "swing.yaml").write_text(MACHINE.format(goal=np.round(goal, 4).tolist()))
    (tmp_path / "scenario.yaml").write_text(SCENARIO)
    probe = Probe()
    result = run_episode(load_scenario(str(tmp_path / "scenario.yaml")), 0, [probe])
    assert result.outcome == "succeeded", result.reason
    # measured on the arm, every physics step (20 rad/s^2 would be 2.7x joint 2's limit)
    assert probe.accel <= 1.0, f"joint acceleration {probe.accel:.3f}x limit at {probe.accel_at}"
    assert probe.speed <= 1.0, f"joint speed {probe.speed:.3f}x limit"
    assert probe.accel > 0.5  # it did move fast: lowered, not crawled
    lowered = [m for m in probe.messages if "lowered to" in m]
    assert lowered and "lowered to 1.85 rad/s, 5.25 rad/s^2" in lowered[0], lowered
