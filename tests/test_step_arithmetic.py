"""The per-step arithmetic done in buffers equals the plain expressions, bit for bit.

The encoders and the controller compute into buffers they keep (docs/performance.md): these
tests hold them to the textbook formulas exactly, and check that a reading or a torque handed
out earlier is never changed by a later step.
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
from orchestrator.robots import Controller, get_robot

from orchestrator.world.sensors import JointEncoders
from orchestrator.world.step_clock import StepClock

DT = 0.002


def test_quantized_encoders_are_the_rounded_positions_and_filtered_differences_exactly():
    rng = np.random.default_rng(7)
    qpos, qvel = rng.normal(size=30), rng.normal(size=30)
    clock = StepClock()
    res = 1.1984224905356572e-05
    enc = JointEncoders(qpos, qvel, slice(3, 15), slice(3, 15), 10, rng, res, clock)
    omega = 2.0 * math.pi * 100.0
    readings, prev, prev_t = [], None, math.nan
    for k in range(500):
        clock.t = k * DT
        qpos[:] += rng.normal(size=30) * 1e-3
        qvel[:] = rng.normal(size=30)
        q, v = enc.read()
        want_q = np.round(qpos[3:15] / res) * res
        if prev is None:
            want_v = np.round(qvel[3:15] / res) * res
        else:
            dt = clock.t - prev_t
            raw = (want_q - prev[0]) / dt
            want_v = prev[1] + (1.0 - math.exp(-omega * dt)) * (raw - prev[1])
        np.testing.assert_array_equal(q, want_q)
        np.testing.assert_array_equal(v, want_v)
        assert enc.read()[0] is q  # the same instant reads the same measurement
        readings.append((q, q.copy(), v, v.copy()))
        prev, prev_t = (want_q, want_v), clock.t
    for q, q_then, v, v_then in readings:  # nothing handed out was overwritten later
        np.testing.assert_array_equal(q, q_then)
        np.testing.assert_array_equal(v, v_then)


def test_joint_impedance_torque_and_setpoint_advance_are_the_plain_formulas_exactly():
    robot = get_robot("mobile_panda")
    ctl = Controller(robot, DT)
    model, data = robot.pinocchio_model(), robot.pinocchio_model().createData()
    n = robot.n_arm
    rng = np.random.default_rng(3)
    q_d = np.array(robot.home) + rng.normal(size=n) * 0.05
    qd_d, qdd_d = rng.normal(size=n) * 0.2, rng.normal(size=n)
    ctl.set_joint_target(q_d, qd_d, qdd_d)
    taus = []
    for _ in range(50):
        q = np.array([*robot.home, 0.04, 0.04]) + rng.normal(size=n + 2) * 0.01
        qd = rng.normal(size=n + 2) * 0.1
        ff = pin.rnea(model, data, q, qd, np.concatenate([qdd_d, np.zeros(2)]))[:n]
        want = ctl.kp * (q_d - q[:n]) + ctl.kd * (qd_d - qd[:n]) + ff
        want = np.maximum(np.minimum(want, ctl.effort_limit), -ctl.effort_limit)
        tau = ctl.compute(q, qd)
        np.testing.assert_array_equal(tau, want)
        taus.append(tau.copy())
        q_d = q_d + (qd_d + 0.5 * DT * qdd_d) * DT
        qd_d = qd_d + qdd_d * DT
        np.testing.assert_array_equal(ctl.q_d, q_d)
        np.testing.assert_array_equal(ctl.qd_d, qd_d)
    assert len({t.tobytes() for t in taus}) == len(taus)


def test_hold_torque_is_the_plain_formula_exactly():
    robot = get_robot("panda")
    ctl = Controller(robot, DT)
    model, data = robot.pinocchio_model(), robot.pinocchio_model().createData()
    hold_at = np.array(robot.home) + 0.02
    ctl.hold(hold_at)
    rng = np.random.default_rng(5)
    for _ in range(20):
        q = np.array([*robot.home, 0.04, 0.04]) + rng.normal(size=9) * 0.01
        qd = rng.normal(size=9) * 0.1
        g = pin.computeGeneralizedGravity(model, data, q)[:7]
        want = ctl.kp * (hold_at - q[:7]) - ctl.kd * qd[:7] + g
        want = np.maximum(np.minimum(want, ctl.effort_limit), -ctl.effort_limit)
        np.testing.assert_array_equal(ctl.compute(q, qd), want)


def test_paths_sample_the_plain_formulas_exactly():
    """The path samplers (called on every IK step of a move's dry runs) give the textbook
    expressions bit for bit: np.interp on the sample grid, rot0 @ SO3.exp(frac delta)."""
    import mink
    from orchestrator.skills.blended_path import BlendedPath
    from orchestrator.skills.targets import rot_down
    from orchestrator.skills.trajectory import CartesianLine

    pts = np.array([[0.4, 0.0, 0.5], [0.5, 0.2, 0.4], [0.6, -0.1, 0.3], [0.45, 0.0, 0.2]])
    path = BlendedPath(pts, rot_down(0.0), rot_down(1.0), 0.3, 1.0, 1.0, 3.0, 0.05)
    line = CartesianLine(pts[0], rot_down(0.3), pts[-1], rot_down(-0.8), 0.3, 1.0, 1.0, 3.0)
    for t in np.linspace(-0.1, path.duration + 0.1, 300):
        s = path.progress(float(t))
        pos, rot = path.sample_so3(float(t))
        want = [np.interp(s, path._s, path._xyz[:, i]) for i in range(3)]
        frac = min(1.0, s / path.s_rot)
        np.testing.assert_array_equal(pos, want)
        np.testing.assert_array_equal(rot.wxyz, (path.rot0 @ mink.SO3.exp(frac * path.delta)).wxyz)
    turns = set()
    for t in np.linspace(0.0, line.duration, 100):
        s, _ = line.profile.progress(float(t))
        _, rot = line.sample_so3(float(t))
        want = (line.rot0 @ mink.SO3.exp(s * line.delta)).wxyz
        np.testing.assert_array_equal(rot.wxyz, want)
        turns.add(rot.wxyz.tobytes())
    assert len(turns) > 90  # the samples turn along the line
