"""The controlled stop: every abort, e-stop and end of a run leaves the arm at rest, held."""

from __future__ import annotations

import numpy as np
import pytest
from orchestrator.robots import Controller, get_robot

from orchestrator.engine.runner import run_episode
from orchestrator.language.load import load_scenario

REST_RAD_S = 0.01
WORKSPACE_WALL = "guards.workspace.max=[0.95,0.1,1.2]"
"""A workspace wall the cube's transport crosses at speed (y = 0.1 m)."""


class JointSpeeds:
    """Largest arm joint speed [rad/s] per control tick, with the state."""

    def on_start(self, ctx, executor):
        self.rows: list[tuple[float, str, float]] = []

    def on_tick(self, ctx, executor):
        speed = float(np.max(np.abs(ctx.data.qvel[ctx.world.arm_dof])))
        self.rows.append((ctx.t, executor.leaf, speed))

    def on_end(self, ctx, executor, result):
        pass


class HoldSpeeds:
    """Largest arm joint speed [rad/s] of every physics step after the stop is at rest."""

    def on_start(self, ctx, executor):
        self.executor = executor
        self.speeds: list[float] = []

    def on_tick(self, ctx, executor):
        pass

    def on_step(self, ctx):
        stop = self.executor.stop
        if stop is not None and stop.at_rest:
            self.speeds.append(float(np.max(np.abs(ctx.data.qvel[ctx.world.arm_dof]))))

    def on_end(self, ctx, executor, result):
        self.braked = set(ctx.world.braked)


def test_controller_brake_profile_stops_2_rad_s_in_time():
    robot = get_robot("panda")
    ctrl = Controller(robot, 0.002)
    q = np.array(robot.home)
    qd = np.zeros(7)
    qd[0] = 2.0
    duration = ctrl.brake(q, qd, 15.0)
    assert duration == pytest.approx(2.0 / 15.0)  # 133 ms at 15 rad/s^2
    assert ctrl.brake(q, np.zeros(7), 15.0) == 0.0  # already still: just hold
    assert ctrl.mode.value == "hold"


def test_a_guard_abort_brakes_to_rest_within_150_ms_and_holds():
    probe = JointSpeeds()
    result = run_episode(load_scenario("pick_place", [WORKSPACE_WALL]), 3, [probe])
    assert result.outcome == "aborted" and result.reason["guard"] == "workspace"
    assert result.final_state == "SAFE_STOP"
    m = result.metrics
    assert 0.0 < m["stop_time_s"] <= 0.15
    assert m["stop_distance_mm"] > 0.0
    stopped_at = m["abort_t"] + m["stop_time_s"]
    after = [speed for t, leaf, speed in probe.rows if t >= stopped_at + 0.01]
    assert after and max(after) < REST_RAD_S  # at rest, and it stays so while held
    assert m["rest_speed_rad_s"] < REST_RAD_S


def test_an_estop_outranks_the_machines_on_abort():
    # the arm moving above the phantom, 1 s in: the root's on_abort (SAFE_HOLD) applies there too
    result = run_episode(load_scenario("surgical", faults=["estop@SETUP.ABOVE+0.2"]), 0)
    assert result.outcome == "aborted" and result.reason["guard"] == "estop"
    assert result.final_state == "SAFE_STOP"  # not SAFE_HOLD: an e-stop cannot be remapped
    assert all(not t["to"].startswith("SAFE_HOLD") for t in result.transitions)


def test_a_time_limit_inside_the_safety_response_still_ends_aborted():
    loaded = load_scenario("pick_place", ["physics.time_limit_s=1.205"], ["estop@1.2"])
    result = run_episode(loaded, 3)
    assert result.outcome == "aborted" and result.reason["guard"] == "estop"
    assert result.metrics["rest_speed_rad_s"] < REST_RAD_S
    assert result.metrics["stop_time_s"] <= 0.15


def test_a_huge_hold_is_cut_at_the_time_limit_and_still_aborted():
    loaded = load_scenario(
        "pick_place", ["physics.safe_stop.hold_s=100000", "physics.time_limit_s=3"], ["estop@1.0"]
    )
    result = run_episode(loaded, 3)
    assert result.outcome == "aborted"
    assert result.sim_time == pytest.approx(3.0, abs=0.02)
    assert result.metrics["rest_speed_rad_s"] < REST_RAD_S


def test_the_time_limit_brings_a_moving_arm_to_rest_before_the_run_ends():
    probe = JointSpeeds()
    result = run_episode(load_scenario("pick_place", ["physics.time_limit_s=0.6"]), 3, [probe])
    assert result.outcome == "failed" and result.metrics["time_limit_reached"]
    # the result says why it ended: the time limit, with its figures (not a null reason)
    assert result.reason is not None and result.reason["kind"] == "time_limit"
    assert "time_limit_s" in result.reason["message"] and result.reason["limit"] == 0.6
    assert result.reason["value"] >= 0.6 - 1e-6
    moving = [speed for t, _, speed in probe.rows if 0.55 <= t <= 0.6]
    assert max(moving) > 0.5  # it was moving fast when the time ran out...
    assert result.metrics["rest_speed_rad_s"] < REST_RAD_S  # ...and ended still
    assert result.sim_time < 0.6 + 0.5


def test_a_failed_final_state_leaves_the_arm_at_rest():
    # every grasp closes on air: the run ends in FAILED after the retries
    result = run_episode(load_scenario("pick_place", ["grasp_offset=[0.0, 0.0, 0.06]"]), 3)
    assert result.outcome == "failed" and result.final_state == "FAILED"
    assert result.metrics["rest_speed_rad_s"] < REST_RAD_S


def test_the_stop_never_pushes_into_an_obstacle_it_hit():
    obstacle = "obstacle:pos=[0.5,0.17,0.45],size=[0.08,0.03,0.08]@TRANSPORT+0.05"
    result = run_episode(load_scenario("pick_place", faults=[obstacle]), 3)
    assert result.reason["guard"] == "collision"
    assert result.metrics["stop_distance_mm"] < 8.0  # hit at 0.8 m/s: contact + rebound only
    assert result.metrics["rest_speed_rad_s"] < REST_RAD_S


@pytest.mark.parametrize(
    "fault", ["actuator_lost", "actuator_saturate:fraction=0.05"], ids=["lost", "saturated"]
)
def test_the_brakes_hold_the_stopped_arm_with_a_failed_motor(fault):
    # joint 2's motor fails while the arm approaches the cube: sensor_health stops the arm,
    # then the holding brakes keep it still over the whole hold, every physics step (the
    # motors alone let joint 2 sag at 0.022-0.024 rad/s under gravity)
    probe = HoldSpeeds()
    loaded = load_scenario("pick_place", faults=[f"{fault}@PICK.GRASP.APPROACH+0.75"])
    result = run_episode(loaded, 0, [probe])
    assert result.reason["guard"] == "sensor_health" and result.final_state == "SAFE_STOP"
    hold_steps = round(loaded.scenario.physics.safe_stop.hold_s / 0.002)
    assert len(probe.speeds) >= hold_steps
    assert max(probe.speeds) < REST_RAD_S
    assert probe.braked == set(range(7))  # a category-1 stop: every joint's brake holds


def test_the_stop_reports_the_profiles_own_distance_and_stays_near_it():
    # an e-stop at 0.93 m/s (carrying the cube) and one at 0.25 m/s (lifting it)
    fast = run_episode(load_scenario("pick_place", faults=["estop@TRANSPORT+0.4"]), 0)
    slow = run_episode(load_scenario("pick_place", faults=["estop@PICK.GRASP.LIFT+0.1"]), 0)
    for result in (fast, slow):
        m = result.metrics
        assert 0.0 < m["stop_distance_min_mm"] <= m["stop_distance_mm"]
    assert fast.metrics["stop_speed_m_s"] > 0.9
    assert fast.metrics["stop_distance_mm"] <= 1.25 * fast.metrics["stop_distance_min_mm"]
    assert slow.metrics["stop_speed_m_s"] <= 0.25
    assert slow.metrics["stop_distance_mm"] <= 5.0
