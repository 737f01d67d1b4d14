"""The safety guards added for faults: collision, sensor_health, joint_velocity, joint_torque,
grasp_lost — each fires on what it watches and stays quiet otherwise."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest
from orchestrator.robots import Controller

from orchestrator.engine.blackboard import Blackboard
from orchestrator.engine.cell import Cell
from orchestrator.engine.context import Context
from orchestrator.guards import (
    Collision,
    GraspLost,
    JointLimits,
    JointTorque,
    JointVelocity,
    SensorHealth,
)
from orchestrator.language.load import load_scenario
from orchestrator.world import World
from orchestrator.world.actuators import ActuatorFault
from orchestrator.world.sensors import WristForceFault

FOLDED_ONTO_ITSELF = [0.0, -1.7, 0.0, -3.0, 0.0, 0.5, 0.0]
"""Arm angles [rad] where the hand and link 7 lie against links 1 and 2 (and nothing else)."""


def _ctx(scenario: str = "pick_place") -> Context:
    world = World.build(load_scenario(scenario).scenario, seed=0)
    ctrl = Controller(world.robot, float(world.model.opt.timestep))
    ctrl.hold(world.home)
    ctx = Context(Cell(world, ctrl, 0), Blackboard())
    ctrl.tau[:] = world.data.ctrl[world.arm_act]  # what the runner does every step
    mujoco.mj_forward(world.model, world.data)
    return ctx


def _guard(cls, ctx: Context, **params):
    guard = cls(cls.Params.model_validate(params))
    guard.bind(ctx)
    guard.activate(ctx)
    return guard


def _pose(ctx: Context, q: list[float]) -> None:
    ctx.data.qpos[ctx.world.arm_qpos] = q
    mujoco.mj_forward(ctx.model, ctx.data)


# -- collision --------------------------------------------------------------------------------


def test_collision_is_quiet_at_home_with_the_cube_on_the_table():
    ctx = _ctx()
    assert _guard(Collision, ctx).check(ctx) is None


def test_collision_fires_on_self_collision_of_the_links():
    ctx = _ctx()
    _pose(ctx, FOLDED_ONTO_ITSELF)
    violation = _guard(Collision, ctx).check(ctx)
    assert violation is not None and violation.guard == "collision"
    assert "panda_hand ~" in violation.message and "panda_link1" in violation.message


def test_collision_fires_when_a_finger_touches_the_table_unless_allowed():
    ctx = _ctx()
    # the table raised under the gripper at home: the fingertips dip into its top
    m = ctx.model
    table = m.body("table").id
    top = m.geom("table_top").id
    m.geom_size[top][:2] = 0.04  # a small block right under the gripper, clear of the links
    half_height = float(m.geom_size[top][2])
    m.body_pos[table][:2] = ctx.tcp_pos[:2]
    m.body_pos[table][2] = float(ctx.tcp_pos[2]) - half_height + 0.002
    ctx.world.static_moved()  # a static body moved: MuJoCo places it again
    assert _guard(Collision, ctx).check(ctx) is not None
    assert _guard(Collision, ctx, allow=["table"]).check(ctx) is None


def test_collision_allows_the_fingers_on_free_objects():
    ctx = _ctx()
    cube = ctx.world.objects["cube"]
    adr = cube.qpos_adr
    # the cube between the fingers, touching them
    ctx.data.qpos[adr : adr + 3] = ctx.tcp_pos
    ctx.data.qpos[ctx.world.finger_qpos] = 0.024
    mujoco.mj_forward(ctx.model, ctx.data)
    m, d = ctx.model, ctx.data
    bodies = {m.body(f).id for f in ctx.world.robot.finger_bodies}
    pairs = {frozenset(int(m.geom_bodyid[g]) for g in d.contact.geom[i]) for i in range(d.ncon)}
    assert any(frozenset((f, m.body("cube").id)) in pairs for f in bodies)  # the contact...
    # ...always allowed, so no sensor counts it (each would cost mj_step a walk of the list)
    assert not [s for s in ctx.world.contact_sensors if s.partner == "cube"]
    violation = _guard(Collision, ctx).check(ctx)
    assert violation is None or "finger" not in violation.message  # ...and is not a collision


# -- joint_velocity ---------------------------------------------------------------------------


def test_joint_velocity_fires_above_the_datasheet_limit_only():
    ctx = _ctx()
    guard = _guard(JointVelocity, ctx)
    ctx.data.qvel[ctx.world.arm_dof[0]] = 2.1  # joint 1's limit is 2.175 rad/s
    assert guard.check(ctx) is None
    ctx.data.qvel[ctx.world.arm_dof[0]] = -2.2
    violation = guard.check(ctx)
    assert violation is not None and violation.limit == pytest.approx(2.175)
    assert "joint 1" in violation.message


def test_joint_velocity_rejects_a_wrong_number_of_limits():
    ctx = _ctx()
    with pytest.raises(ValueError, match="7 values"):
        _guard(JointVelocity, ctx, limits_rad_s=[1.0, 1.0])


# -- joint_torque -----------------------------------------------------------------------------


def test_joint_torque_fires_after_the_duration_and_forgets_interruptions():
    ctx = _ctx()
    guard = _guard(JointTorque, ctx, fraction=0.9, duration_ms=20.0)  # 10 physics steps
    tau = ctx.controller.tau
    tau[1] = 80.0  # 0.92 of joint 2's 87 Nm
    assert all(guard.check(ctx) is None for _ in range(9))
    tau[1] = 10.0  # one quiet step resets the count
    assert guard.check(ctx) is None
    tau[1] = -80.0
    assert all(guard.check(ctx) is None for _ in range(9))
    violation = guard.check(ctx)
    assert violation is not None and "joint 2" in violation.message


# -- sensor_health ----------------------------------------------------------------------------


def test_sensor_health_is_quiet_on_healthy_sensors():
    ctx = _ctx()
    assert _guard(SensorHealth, ctx).check(ctx) is None


@pytest.mark.parametrize(
    ("kind", "offset", "words"),
    [
        ("ft_nan", (0.0, 0.0, 0.0), "non-finite"),
        ("ft_bias", (0.0, 0.0, 150.0), "beyond the sensor's range"),
    ],
)
def test_sensor_health_catches_a_bad_force_reading(kind, offset, words):
    ctx = _ctx()
    ctx.cell.wrist.fault = WristForceFault(kind, ctx.t, offset, math.inf)
    ctx.cell.wrist._norm_sq_t = -1.0  # a new reading
    violation = _guard(SensorHealth, ctx).check(ctx)
    assert violation is not None and words in violation.message


def test_sensor_health_catches_a_stale_force_sensor_after_its_timeout():
    ctx = _ctx()
    guard = _guard(SensorHealth, ctx, ft_stale_ms=10.0)
    ctx.cell.wrist.fault = WristForceFault("ft_dropout", ctx.t, (0.0, 0.0, 0.0), math.inf)
    ctx.world.step_clock.t += 0.008
    assert guard.check(ctx) is None
    ctx.world.step_clock.t += 0.004
    violation = guard.check(ctx)
    assert violation is not None and "stale" in violation.message


def test_sensor_health_compares_each_encoder_with_its_safety_encoder():
    ctx = _ctx()
    guard = _guard(SensorHealth, ctx, encoder_tolerance_rad=0.01)
    ctx.cell.encoders.inject("encoder_freeze", 3)
    assert guard.check(ctx) is None  # frozen where it is: no disagreement yet
    ctx.data.qpos[ctx.world.arm_qpos[2]] += 0.02  # the joint moves on, its encoder does not
    violation = guard.check(ctx)
    assert violation is not None and "joint 3 encoder" in violation.message


def test_sensor_health_compares_commanded_and_measured_joint_torque():
    ctx = _ctx()
    guard = _guard(SensorHealth, ctx)
    act = ctx.world.arm_act
    ctx.controller.tau[:] = ctx.data.qfrc_bias[ctx.world.arm_dof]
    ctx.controller.tau[1] = -20.0  # more than the derated motor's 4.35 Nm
    fault = ActuatorFault("actuator_saturate", 1, 87.0, fraction=0.05)
    ctx.data.ctrl[act] = fault.apply(ctx.controller.tau)
    mujoco.mj_forward(ctx.model, ctx.data)
    violation = guard.check(ctx)
    assert violation is not None and "joint 2 motor delivers" in violation.message
    ctx.data.ctrl[act] = ctx.controller.tau  # a healthy motor delivers what it is told
    mujoco.mj_forward(ctx.model, ctx.data)
    assert guard.check(ctx) is None


def test_sensor_health_flags_a_non_finite_joint_reading_without_an_encoder_fault():
    ctx = _ctx()
    guard = _guard(SensorHealth, ctx)
    assert guard.check(ctx) is None
    ctx.data.qpos[ctx.world.arm_qpos[4]] = np.nan  # both channels read NaN: NaN != NaN
    violation = guard.check(ctx)
    assert violation is not None and "joint 5 encoder reads a non-finite" in violation.message


# -- joint_limits -----------------------------------------------------------------------------


def test_joint_limits_reads_the_joints_as_they_move_after_binding():
    ctx = _ctx()
    guard = _guard(JointLimits, ctx, margin_rad=0.01)
    assert guard.check(ctx) is None
    j4 = ctx.world.arm_qpos[3]
    upper = float(ctx.model.jnt_range[ctx.model.joint("panda_joint4").id, 1])
    ctx.data.qpos[j4] = upper - 0.005  # inside the range, beyond the margin
    violation = guard.check(ctx)
    assert violation is not None and "panda_joint4" in violation.message
    assert violation.limit == pytest.approx(upper - 0.01)
    ctx.data.qpos[j4] = np.nan  # divergence is the runner's to report
    assert guard.check(ctx) is None


# -- grasp_lost -------------------------------------------------------------------------------


def test_grasp_lost_fires_when_the_fingers_close_past_the_held_width():
    ctx = _ctx()
    fingers = ctx.world.finger_qpos
    ctx.data.qpos[fingers] = 0.025  # holding a 5 cm cube
    guard = _guard(GraspLost, ctx, tolerance_m=0.005)
    ctx.data.qpos[fingers] = 0.024
    assert guard.check(ctx) is None
    ctx.data.qpos[fingers] = 0.02
    violation = guard.check(ctx)
    assert violation is not None and "slipped out" in violation.message
