"""The in-place IK QP (skills/ik_qp.py) returns mink.solve_ik's velocity, bit for bit."""

from __future__ import annotations

import mink
import numpy as np
import pytest
from orchestrator.robots import get_robot
from orchestrator.skills.ik import IKSolver
from orchestrator.skills.ik_qp import IKProblem
from orchestrator.skills.targets import rot_down

from orchestrator.world.world import robot_only_model


def _solver(robot_name: str) -> IKSolver:
    robot = get_robot(robot_name)
    ik = IKSolver(robot, robot_only_model(robot), 0.01, np.zeros(3))
    ik.reset(np.array(robot.home))
    return ik


def _mink_velocity(ik: IKSolver, dt: float) -> np.ndarray:
    return mink.solve_ik(ik.config, ik.tasks, dt, "daqp", damping=ik.damping, limits=ik.limits)


@pytest.mark.parametrize("robot_name", ["panda", "mobile_panda"])
def test_ik_problem_gives_mink_solve_ik_bit_for_bit(robot_name):
    """Random reachable and unreachable targets from random joint angles (some at their
    limits, where the configuration limit is active), with the posture gain the solver uses
    at any point of its ramp: every velocity equals mink's exactly."""
    ik = _solver(robot_name)
    rng = np.random.default_rng(7)
    model = ik.config.model
    lower, upper = model.jnt_range[:, 0], model.jnt_range[:, 1]
    problem = IKProblem(ik.config, ik.tasks, ik.limits, ik.damping)
    p0, _ = ik.tcp_pose()
    active = 0
    for trial in range(60):
        q = ik.config.q.copy()
        q[: ik.n] = rng.uniform(lower[: ik.n], upper[: ik.n]) * 0.9
        if trial % 5 == 0:  # a joint at its limit: the configuration limit binds
            j = int(rng.integers(ik.n))
            q[j] = upper[j] if model.jnt_limited[j] else q[j]
        ik.config.update(q)
        ik.frame_task.set_target(
            mink.SE3.from_rotation_and_translation(
                mink.SO3.from_matrix(rot_down(rng.uniform(-3, 3))),
                p0 + rng.normal(scale=0.3, size=3),
            )
        )
        if hasattr(ik.posture_task, "gain"):
            ik.posture_task.gain = float(rng.uniform(0.0, 0.05))
        dt = float(rng.choice([0.01, 0.03]))
        fast = problem.solve(dt)
        ref = _mink_velocity(ik, dt)
        assert np.array_equal(fast, ref), f"trial {trial}: {np.max(np.abs(fast - ref))}"
        active += bool(np.any(np.abs(fast * dt) >= 0.999 * problem._h[: 2 * ik.n].min()))
    assert active > 0  # some trials ran against a limit


def test_ik_solver_along_a_motion_matches_mink_bit_for_bit():
    """Two solvers integrating their own references along the same targets, one through
    IKProblem, one through mink.solve_ik: the same joint angles at every tick."""
    fast, ref = _solver("panda"), _solver("panda")
    ref._solve = lambda dt: _mink_velocity(ref, dt)  # type: ignore[method-assign]
    p0, rot = fast.tcp_pose()
    for i in range(200):
        target = p0 + np.array([0.3 * np.sin(i / 30), 0.2 * (1 - np.cos(i / 40)), -0.001 * i])
        fast.reference_step(target, rot, 0.01)
        ref.reference_step(target, rot, 0.01)
        assert np.array_equal(fast.config.q, ref.config.q), f"tick {i}"


def test_ik_problem_refuses_what_it_cannot_assemble():
    ik = _solver("panda")
    com = mink.ComTask(cost=1.0)
    assert not IKProblem.supports([*ik.tasks, com], ik.limits)
    with pytest.raises(ValueError, match="ComTask"):
        IKProblem(ik.config, [*ik.tasks, com], ik.limits, ik.damping)
    ik.tasks = [*ik.tasks, com]  # the solver falls back to mink.solve_ik
    com.set_target(np.array([0.1, 0.0, 0.4]))
    p, rot = ik.tcp_pose()
    v = ik.reference_step(p, rot, 0.01)
    assert ik._problem is None and np.all(np.isfinite(v))


def test_constant_rows_are_rewritten_when_a_cost_or_the_step_changes():
    """The posture and damping rows and the velocity limits' h are kept between calls
    (they do not depend on the configuration): a cost changed in place (`set_cost`), a
    damping task's gain, or another dt must still give mink's velocity exactly."""
    ik = _solver("mobile_panda")
    problem = IKProblem(ik.config, ik.tasks, ik.limits, ik.damping)
    posture, damping = ik.tasks[1], ik.tasks[2]
    assert type(posture) is mink.PostureTask and type(damping) is mink.DampingTask
    p0, rot = ik.tcp_pose()
    ik.frame_task.set_target(
        mink.SE3.from_rotation_and_translation(mink.SO3.from_matrix(rot), p0 + 0.4)
    )
    first = problem.solve(0.01)
    changes = [
        lambda: posture.set_cost(posture.cost * 50.0),  # in place: the same array object
        lambda: damping.set_cost(damping.cost * 0.1),
        lambda: setattr(damping, "gain", 0.5),  # its error is zero: the same solution
        lambda: None,  # only dt changes below
    ]
    seen = {first.tobytes()}
    for k, change in enumerate(changes):
        change()
        dt = 0.03 if k == 3 else 0.01
        fast = problem.solve(dt)
        assert np.array_equal(fast, _mink_velocity(ik, dt)), f"change {k}"
        seen.add(fast.tobytes())
    assert len(seen) == 4  # every cost and the step moved the solution: rows rewritten
