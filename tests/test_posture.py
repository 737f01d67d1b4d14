"""The nullspace posture's projector: the 6x6-inverse form equals the pseudo-inverse's."""

from __future__ import annotations

import numpy as np
from orchestrator.robots import get_robot
from orchestrator.skills.ik import IKSolver
from orchestrator.skills.posture import NullspacePostureTask
from scipy.linalg.lapack import dpotrf, dtrtri

from orchestrator.world.world import robot_only_model


def _panda_ik() -> IKSolver:
    robot = get_robot("panda")
    ik = IKSolver(robot, robot_only_model(robot), 0.01, np.zeros(3))
    ik.reset(np.array(robot.home))
    ik.frame_task.set_target_from_configuration(ik.config)
    return ik


def test_projector_equals_the_pseudo_inverse_one_on_random_configurations():
    ik = _panda_ik()
    task = ik.posture_task
    assert isinstance(task, NullspacePostureTask)
    model = ik.config.model
    rng = np.random.default_rng(3)
    worst, fast = 0.0, 0
    for _ in range(2000):
        ik.config.update(rng.uniform(model.jnt_range[:, 0], model.jnt_range[:, 1]))
        jac = ik.frame_task.compute_jacobian(ik.config)
        gram = jac @ jac.T
        fast += np.trace(np.linalg.inv(gram)) * np.trace(gram) * 1e-6 <= 1.0
        worst = max(
            worst, float(np.max(np.abs(task.projector_from(jac) - task.pinv_projector(jac))))
        )
    assert worst < 1e-9, f"max |N - N_pinv| = {worst:.2e}"
    assert fast > 1900  # the inverse, not the SVD, did nearly all of them


def _plain_projector(task: NullspacePostureTask, jac: np.ndarray) -> np.ndarray:
    """`projector_from` as plain expressions (`@`, `.sum()`, fresh arrays)."""
    gram = jac @ jac.T
    factor, info = dpotrf(gram, lower=1, clean=1)
    if info == 0:
        inverse, info = dtrtri(factor, lower=1)
        if info == 0 and (inverse * inverse).sum() * gram.trace() * 1e-6 <= 1.0:
            y = inverse @ jac
            return np.eye(jac.shape[1]) - y.T @ y
    return np.eye(jac.shape[1]) - np.linalg.pinv(jac, rcond=1e-3) @ jac


def test_projector_is_its_plain_expressions_bit_for_bit():
    """`projector_from` (np.dot into a kept array, np.add.reduce) computes what the plain
    expressions compute, to the last bit, with and without `out`: scaled Jacobians of random
    configurations, well inside and near the cut (both forms used)."""
    ik = _panda_ik()
    task = ik.posture_task
    assert isinstance(task, NullspacePostureTask)
    model = ik.config.model
    rng = np.random.default_rng(11)
    out = np.empty((model.nv, model.nv))
    calls = {"pinv": 0}
    pinv = task.pinv_projector

    def counting(jac, out=None):
        calls["pinv"] += 1
        return pinv(jac, out)

    task.pinv_projector = counting  # type: ignore[method-assign]
    for trial in range(1500):
        ik.config.update(rng.uniform(model.jnt_range[:, 0], model.jnt_range[:, 1]))
        jac = ik.frame_task.compute_jacobian(ik.config) * 10 ** rng.uniform(-2, 1)
        if trial % 3 == 0:  # the last joint column scaled towards 0: near the cut
            jac[:, 6] *= 10 ** rng.uniform(-5, 0)
        plain = _plain_projector(task, jac)
        assert np.array_equal(task.projector_from(jac), plain), trial
        assert task.projector_from(jac, out=out) is out
        assert np.array_equal(out, plain), trial
    assert 0 < calls["pinv"] < 1000  # both forms


def test_projector_near_and_at_a_singularity_stays_a_projector():
    """A Jacobian whose smallest singular value goes from 0.1 to exactly 0 (the two finger
    columns zero, as the Panda's): at every step the projector is symmetric, idempotent,
    annihilates the task directions it keeps, and equals the pseudo-inverse one; below the
    cut (1e-3 of the largest) the vanishing direction is handed to the posture."""
    ik = _panda_ik()
    task = ik.posture_task
    rng = np.random.default_rng(5)
    u, _ = np.linalg.qr(rng.normal(size=(6, 6)))
    v, _ = np.linalg.qr(rng.normal(size=(7, 7)))
    for s_min in [1e-1, 1e-2, 3e-3, 1.9e-3, 1.7e-3, 1e-4, 1e-8, 0.0]:
        sigma = np.array([1.8, 1.6, 1.1, 0.34, 0.3, s_min])
        jac = np.zeros((6, 9))
        jac[:, :7] = u @ np.diag(sigma) @ v[:6]
        null = task.projector_from(jac)
        assert np.all(np.isfinite(null))
        np.testing.assert_allclose(null, null.T, atol=1e-12)
        np.testing.assert_allclose(null @ null, null, atol=1e-9)
        np.testing.assert_allclose(null, task.pinv_projector(jac), atol=1e-9)
        kept = sigma > 1e-3 * sigma[0]
        rows = v[:6][kept]  # the joint directions the TCP task moves along
        assert np.max(np.abs(null[:7, :7] @ rows.T)) < 1e-9
        rank = round(float(np.trace(null)))
        assert rank == 9 - int(np.count_nonzero(kept)), f"s_min {s_min}: trace {rank}"


def test_ik_along_a_stretch_to_the_edge_of_reach_stays_smooth():
    """Reaching out towards and past the edge of the workspace (the arm straightens, the
    elbow's singular value falls): the IK's steps stay finite and bounded, the posture never
    yanks the joints, and both the inverse and the pseudo-inverse forms are used."""
    ik = _panda_ik()
    task = ik.posture_task
    calls = {"pinv": 0}
    pinv = task.pinv_projector

    def counting(jac, out=None):
        calls["pinv"] += 1
        return pinv(jac, out)

    task.pinv_projector = counting
    p0, rot = ik.tcp_pose()
    steps = 0
    for i in range(400):
        target = p0 + np.array([0.0025 * i, 0.0, 0.001 * i])  # to 1 m further out
        v = ik.reference_step(target, rot, 0.01)
        assert np.all(np.isfinite(v))
        assert np.max(np.abs(v)) <= 2.0 + 1e-9  # the IK's velocity limit
        steps += 1
    assert 0 < calls["pinv"] < steps
