"""The arm's posture, held in the nullspace of the TCP task: what the IK does with a 7th joint.

A 7-joint arm reaching a 6-D pose has one joint motion left over (the elbow swinging about the
shoulder-wrist line). Left to the solver, it drifts: the least-norm velocity the IK picks is not
integrable, so a closed Cartesian path does not return the joints to where they started (three
rounds of a 20 cm square: 0.40 rad, tests/test_physical_honesty.py). mink's own `PostureTask`
pulls every joint towards the posture, which fights the TCP task: at costs that hold the
posture the TCP misses its target by centimetres (cost 0.1: 29 mm), at costs that do not
(1e-3), it does nothing (0.40 rad of drift either way).

`NullspacePostureTask` pulls only the part of the posture error the TCP task does not use: its
error and Jacobian are projected on the nullspace of the frame task's Jacobian, N = I - J⁺J. In
mink's weighted least squares the two then act on orthogonal joint motions, so the posture can
be held firmly without costing the TCP any accuracy.
"""

from __future__ import annotations

import mink
import mujoco
import numpy as np
from scipy.linalg.lapack import dpotrf, dtrtri

__all__ = ["NullspacePostureTask"]

_RCOND = 1e-3
"""Singular values of the frame Jacobian below this fraction of the largest count as zero: a
direction the TCP task cannot move (at a singularity) is left to the posture."""


class NullspacePostureTask(mink.Task):
    """Hold a joint posture in the nullspace of a frame task.

    Args:
        model: The robot's MjModel (no free joints).
        frame_task: The TCP task whose nullspace the posture lives in.
        cost: Weight of the posture error [1/rad] (mink's convention: the objective weighs
            cost²; the frame task's costs are 1). 0 leaves the redundancy to the solver.
        gain: Fraction of the posture error corrected per IK step, in [0, 1].
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        frame_task: mink.FrameTask,
        cost: float,
        gain: float = 1.0,
    ) -> None:
        if cost < 0.0 or not np.isfinite(cost):
            raise ValueError(f"posture cost {cost} must be finite and >= 0")
        super().__init__(cost=np.full(model.nv, float(cost)), gain=gain)
        self.model = model
        self.frame_task = frame_task
        self.target_q: np.ndarray | None = None
        self._eye = np.eye(model.nv)
        self._diff = np.empty(model.nv)

    def set_target(self, target_q: np.ndarray) -> None:
        """The posture to hold: joint angles [rad]. Shape (nq,)."""
        self.target_q = np.array(target_q, dtype=float)

    def projector(self, configuration: mink.Configuration) -> np.ndarray:
        """N = I - J⁺J of the frame task at `configuration`. Shape (nv, nv)."""
        return self.projector_from(self.frame_task.compute_jacobian(configuration))

    def projector_from(self, jacobian: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        """N = I - J⁺J of the frame task's Jacobian `jacobian` (shape (6, nv)), when the
        caller has it already (skills/ik_qp.py), into `out` if given. Shape (nv, nv).

        Where J has full row rank with every singular value above `_RCOND` of the largest,
        J⁺J = Jᵀ(JJᵀ)⁻¹J = YᵀY with Y = L⁻¹J, L the Cholesky factor of JJᵀ: two 6x6 LAPACK
        calls instead of an SVD (a third of the time, bench/ik_step.py). L⁻¹ proves that
        case: λ_min(JJᵀ) >= 1 / ||L⁻¹||_F² and λ_max(JJᵀ) <= tr(JJᵀ), so
        ||L⁻¹||_F² tr(JJᵀ) _RCOND² <= 1 means no singular value is below the cut (98.4 % of
        uniformly random Panda configurations; the two agree to 5e-12 there,
        tests/test_posture.py). Otherwise (near a singularity, where the bound is
        conservative by at most 36x, or where the Cholesky fails) the pseudo-inverse with its
        cut does it, as before.
        """
        gram = np.dot(jacobian, jacobian.T)  # (np.dot: `@`'s BLAS call, less set-up)
        factor, info = dpotrf(gram, lower=1, clean=1)
        if info == 0:
            inverse, info = dtrtri(factor, lower=1)
            # (np.add.reduce: what `.sum()` calls, without its Python wrapper)
            if (
                info == 0
                and np.add.reduce(inverse * inverse, axis=None) * gram.trace() * _RCOND**2 <= 1.0
            ):
                y = np.dot(inverse, jacobian)
                return np.subtract(self._eye, np.dot(y.T, y), out=out)
        return self.pinv_projector(jacobian, out)

    def pinv_projector(self, jacobian: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        """N = I - J⁺J by the SVD pseudo-inverse, singular values below `_RCOND` of the
        largest cut (the reference for `projector_from`), into `out` if given. Shape (nv, nv)."""
        product = np.linalg.pinv(jacobian, rcond=_RCOND) @ jacobian
        return np.subtract(self._eye, product, out=out)

    def raw_error(self, configuration: mink.Configuration) -> np.ndarray:
        """The joint posture error q ⊖ q* [rad], unprojected. Shape (nv,)."""
        return self.raw_error_view(configuration).copy()

    def raw_error_view(self, configuration: mink.Configuration) -> np.ndarray:
        """`raw_error` into an array the task keeps (overwritten by the next call)."""
        if self.target_q is None:
            raise mink.TargetNotSet(type(self).__name__)
        qpos = configuration.data.qpos  # (`configuration.q` is a copy of it)
        mujoco.mj_differentiatePos(self.model, self._diff, 1.0, self.target_q, qpos)
        return self._diff

    def compute_error(self, configuration: mink.Configuration) -> np.ndarray:
        return self.projector(configuration) @ self.raw_error(configuration)

    def compute_jacobian(self, configuration: mink.Configuration) -> np.ndarray:
        return self.projector(configuration)

    def compute_qp_residual(
        self, configuration: mink.Configuration
    ) -> tuple[np.ndarray, np.ndarray, float]:
        null = self.projector(configuration)  # once for both
        return self._weighted_residual(null @ self.raw_error(configuration), null)
