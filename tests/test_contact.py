"""The `contact` skill alone: force-limited approach, force regulation, and the phantom it
presses on (whose stiffness the scenario sets through MuJoCo's solref/solimp)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from orchestrator.skills.contact import ContactParams
from pydantic import ValidationError

from orchestrator.engine.runner import run_episode
from orchestrator.language.load import load_scenario

# At home the probe tip (20 cm from the flange) is at x = 0.307 m, z = 0.390 m.
MACHINE = """\
name: press
initial: ZERO
states:
  ZERO:
    skill: zero_sensor
    transitions: {{zeroed: PRESS, out_of_tolerance: FAILED}}
  PRESS:
    skill: contact
    with: {with_}
    transitions: {{contacted: DONE, done: DONE, no_contact: MISSED, overforce: OVERFORCE}}
  DONE: {{final: succeeded}}
  MISSED: {{final: no_contact}}
  OVERFORCE: {{final: overforce}}
  FAILED: {{final: failed}}
"""

SCENARIO = """\
name: press
tool: {{name: probe, mass_kg: 0.25, length_m: 0.2}}
scene:
{scene}
machine: press.yaml
physics: {{time_limit_s: 8}}
"""

RIGID_TABLE = "  table: {center_xy: [0.3, 0.0], size_xy: [0.3, 0.3], height: 0.37}"
"""A table (MuJoCo's default, stiff contact) 2 cm below the tip."""


def _scenario(tmp_path: Path, with_: str, scene: str = RIGID_TABLE):
    (tmp_path / "press.yaml").write_text(MACHINE.format(with_=with_))
    path = tmp_path / "scenario.yaml"
    path.write_text(SCENARIO.format(scene=scene))
    return load_scenario(str(path))


class ForceProbe:
    """Samples the zeroed wrist force and the tip every control tick, as the skill sees them."""

    def on_start(self, ctx, executor):
        self.t, self.force, self.tip, self.state = [], [], [], []
        self.dt = ctx.dt_control

    def on_tick(self, ctx, executor):
        self.t.append(ctx.t)
        self.force.append(ctx.wrist_force().copy())
        self.tip.append(ctx.tcp_pos.copy())
        self.state.append(executor.leaf)

    def on_end(self, ctx, executor, result):
        self.world = ctx.world

    def filtered_normal(self, cutoff_hz: float) -> np.ndarray:
        """The upward force low-passed like the skill does (first order, control rate) [N]."""
        alpha = 1.0 - math.exp(-2.0 * math.pi * cutoff_hz * self.dt)
        out, y = [], 0.0
        for f in self.force:
            y += alpha * (f[2] - y)
            out.append(y)
        return np.array(out)

    def pressing(self) -> np.ndarray:
        return np.array([s == "PRESS" for s in self.state])


def _press(tmp_path, stiffness: float):
    with_ = (
        "{target_force_n: 5.0, approach_speed: 0.02, max_travel_m: 0.05, max_force_n: 20.0,"
        f" hold_s: 1.0, filter_hz: 15.0, stiffness_n_per_m: {stiffness}}}"
    )
    probe = ForceProbe()
    result = run_episode(_scenario(tmp_path, with_), 0, [probe])
    return result, probe


def test_approaching_a_rigid_surface_at_2_cm_s_overshoots_5_n_by_at_most_20_percent(tmp_path):
    result, probe = _press(tmp_path, stiffness=800.0)
    assert result.outcome == "succeeded", result.transitions
    pressing = probe.pressing()
    force = probe.filtered_normal(15.0)[pressing]
    overshoot = (force.max() - 5.0) / 5.0
    assert overshoot <= 0.20, f"overshoot {overshoot:.1%}"
    # and the force loop settles on the target
    # (realism on: the reading is noisy and the quantized encoders make the stiff contact
    # chatter by a few tenths of a newton, so the mean settles, each sample within 0.3 N)
    settled = np.array([f[2] for f in probe.force])[pressing][-10:]
    assert abs(settled.mean() - 5.0) < 0.1, settled
    assert np.all(np.abs(settled - 5.0) < 0.3), settled
    # the probe rests on the table: it pressed, it did not push through
    top = 0.37
    assert abs(probe.tip[-1][2] - top) < 0.5e-3


def test_a_stiff_impedance_overshoots_the_same_approach(tmp_path):
    """The bound above is not trivially met: at 5000 N/m the force builds 6x faster than at
    800 N/m while the filtered force catches up, and the overshoot passes 20 %."""
    result, probe = _press(tmp_path, stiffness=5000.0)
    force = probe.filtered_normal(15.0)[probe.pressing()]
    assert (force.max() - 5.0) / 5.0 > 0.20


def test_the_phantom_yields_with_the_stiffness_the_scenario_sets(tmp_path):
    phantom = (
        "  table: {center_xy: [0.3, 0.0], size_xy: [0.3, 0.3], height: 0.33}\n"
        "  phantom: {size: [0.1, 0.1, 0.04], xy: [0.307, 0.0], stiffness_n_per_m: 800,"
        " damping_n_s_per_m: 20}"
    )
    # 1.9 mm deep: less than the ball tip's radius, so the shaft (which collides with tissue)
    # stays out and the tip alone carries the force
    with_ = (
        "{target_force_n: 1.5, approach_speed: 0.01, hold_s: 1.5, surface_stiffness_n_per_m: 800}"
    )
    probe = ForceProbe()
    result = run_episode(_scenario(tmp_path, with_, phantom), 0, [probe])
    assert result.outcome == "succeeded", result.transitions
    end = np.flatnonzero(probe.pressing())[-1]
    force = probe.force[end][2]
    indentation = probe.world.phantom.surface_pos[2] - probe.tip[end][2]
    assert force == pytest.approx(1.5, abs=0.02)
    assert force / indentation == pytest.approx(800.0, rel=0.03)


def test_nothing_within_the_travel_limit_ends_no_contact(tmp_path):
    low_table = "  table: {center_xy: [0.3, 0.0], size_xy: [0.3, 0.3], height: 0.2}"
    with_ = "{target_force_n: 2.0, approach_speed: 0.02, max_travel_m: 0.03}"
    probe = ForceProbe()
    result = run_episode(_scenario(tmp_path, with_, low_table), 0, [probe])
    assert result.final_state == "MISSED"
    travel = probe.tip[0][2] - np.array(probe.tip)[:, 2]
    # it went down the whole way (the tip trails the setpoint by damping x speed / stiffness)
    # and never past the limit
    assert 0.025 < travel[-1] and travel.max() <= 0.03


def test_overforce_releases_the_preload(tmp_path):
    # the impact of a 2 cm/s approach on a rigid surface passes a 2.5 N limit at once
    with_ = "{target_force_n: 2.0, max_force_n: 2.5, approach_speed: 0.02}"
    probe = ForceProbe()
    result = run_episode(_scenario(tmp_path, with_), 0, [probe])
    assert result.final_state == "OVERFORCE"
    assert abs(probe.force[-1][2]) < 0.5  # the spring no longer presses the tip on the table


@pytest.mark.parametrize(("lateral_n", "final"), [(6.0, "OVERFORCE"), (3.0, "DONE")])
def test_a_lateral_load_counts_towards_overforce(tmp_path, lateral_n, final):
    # holding 2 N on the table, the sensor starts to feel a sideways load (the tip caught on
    # something): 6 N sideways passes the 5 N limit though the normal force stays at 2 N;
    # 3 N sideways (3.6 N in total) does not
    with_ = "{target_force_n: 2.0, max_force_n: 5.0, approach_speed: 0.01, hold_s: 2.0}"
    (tmp_path / "press.yaml").write_text(MACHINE.format(with_=with_))
    path = tmp_path / "scenario.yaml"
    path.write_text(SCENARIO.format(scene=RIGID_TABLE))
    fault = f"ft_bias:force_n=[{lateral_n},0,0]@PRESS+2.0"
    result = run_episode(load_scenario(str(path), None, [fault]), 0)
    assert result.final_state == final, result.transitions


def test_the_approach_axis_must_be_a_world_axis():
    with pytest.raises(ValidationError, match="along a world axis"):
        ContactParams.model_validate({"axis": [0.0, 0.6, -0.8]})


def test_the_force_limit_must_exceed_the_target():
    with pytest.raises(ValidationError, match="must exceed target_force_n"):
        ContactParams.model_validate({"target_force_n": 5.0, "max_force_n": 4.0})
