"""The mobile Panda: its base joints, their limits, and the base under the joint servo."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from orchestrator.robots import Controller, get_robot
from orchestrator.robots.mobile import BASE

DT = 0.002


@pytest.fixture(scope="module")
def plant():
    robot = get_robot("mobile_panda")
    model = robot.build_spec().compile()
    model.opt.timestep = DT
    return robot, model


def _at_home(robot, model) -> mujoco.MjData:
    data = mujoco.MjData(model)
    data.qpos[: robot.n_arm] = robot.home
    data.qpos[robot.n_arm : robot.n_arm + 2] = robot.gripper_open_m
    mujoco.mj_forward(model, data)
    return data


def test_base_joints_come_first_with_a_real_bases_limits(plant):
    robot, model = plant
    assert robot.mobile and robot.arm_joints[:3] == robot.base_joints
    assert [model.joint(i).name for i in range(3)] == list(robot.base_joints)
    np.testing.assert_allclose(robot.joint_velocity_limits()[:3], [0.5, 0.5, 1.0])
    assert robot.acceleration_limits[:3] == (1.0, 1.0, 2.0)
    # the chassis clears the floor: the collision guard counts any contact of a robot body
    base = model.body("base_link").id
    lowest = min(
        model.geom_pos[g, 2] - model.geom_size[g, 2]
        for g in range(model.ngeom)
        if model.geom_bodyid[g] == base
    )
    assert lowest == pytest.approx(BASE.clearance_m)
    # pinocchio sees the same chain (base first, then the arm)
    pin_model = robot.pinocchio_model()
    assert list(pin_model.names)[1:4] == list(robot.base_joints)


def _drive(robot, model, data, ctrl, dist, v_max, a_max, axis=0):
    """A trapezoidal profile of `dist` on one base joint; returns the worst tracking error
    and the top speed measured."""
    t_acc = v_max / a_max
    t_flat = dist / v_max - t_acc
    total = 2 * t_acc + t_flat
    worst = top = 0.0
    for k in range(round((total + 0.5) / DT)):
        t = k * DT
        if t < t_acc:
            x, v, a = 0.5 * a_max * t * t, a_max * t, a_max
        elif t < t_acc + t_flat:
            x, v, a = 0.5 * a_max * t_acc**2 + v_max * (t - t_acc), v_max, 0.0
        elif t < total:
            r = total - t
            x, v, a = dist - 0.5 * a_max * r * r, a_max * r, -a_max
        else:
            x, v, a = dist, 0.0, 0.0
        if k % 5 == 0:  # 100 Hz setpoints, as the runner's control ticks
            q, qd, qdd = np.array(robot.home), np.zeros(robot.n_arm), np.zeros(robot.n_arm)
            q[axis], qd[axis], qdd[axis] = x, v, a
            ctrl.set_joint_target(q, qd, qdd)
        data.ctrl[: robot.n_arm] = ctrl.compute(data.qpos[:12].copy(), data.qvel[:12].copy())
        mujoco.mj_step(model, data)
        worst = max(worst, abs(data.qpos[axis] - x))
        top = max(top, abs(data.qvel[axis]))
    return worst, top


@pytest.mark.parametrize(("axis", "dist", "v", "a"), [(0, 1.0, 0.5, 1.0), (2, 1.5, 1.0, 2.0)])
def test_base_tracks_a_profile_at_its_limits_and_the_arm_stays_put(plant, axis, dist, v, a):
    robot, model = plant
    data = _at_home(robot, model)
    ctrl = Controller(robot, DT)
    ctrl.hold(np.array(robot.home))
    worst, top = _drive(robot, model, data, ctrl, dist, v, a, axis)
    assert worst < 0.005  # [m] or [rad]
    assert top <= v * 1.01
    assert abs(data.qpos[axis] - dist) < 1e-3
    arm = slice(3, robot.n_arm)
    assert np.max(np.abs(data.qpos[arm] - np.array(robot.home)[arm])) < 1e-3


def test_a_controlled_stop_brings_the_moving_base_to_rest(plant):
    robot, model = plant
    data = _at_home(robot, model)
    ctrl = Controller(robot, DT)
    data.qvel[0] = 0.5  # driving at full speed
    q0 = float(data.qpos[0])
    duration = ctrl.brake(data.qpos[:12].copy(), data.qvel[:12].copy(), robot.acceleration_limits)
    assert duration == pytest.approx(0.5)  # 0.5 m/s at 1 m/s^2
    for _ in range(round(1.0 / DT)):
        data.ctrl[: robot.n_arm] = ctrl.compute(data.qpos[:12].copy(), data.qvel[:12].copy())
        mujoco.mj_step(model, data)
    assert abs(data.qvel[0]) < 1e-3
    # v^2 / 2a = 0.125 m of braking distance, within the servo's tracking
    assert data.qpos[0] - q0 == pytest.approx(0.125, abs=0.01)
