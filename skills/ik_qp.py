"""The IK's quadratic program, assembled in place: mink's `solve_ik`, without its allocations.

`mink.solve_ik` rebuilds the whole QP on every call: a fresh residual and Jacobian per task,
the frame Jacobian computed twice (once for the TCP task, once again for the nullspace
posture's projector), `vstack`s of the task rows and of the limits' (constant) inequality
matrices, a `qpsolvers.Problem` with its checks, and `configuration.check_limits`, which with
`safety_break=False` only writes debug log lines. At the 100 Hz control rate plus the dry runs
of `time_scaling.py`, that assembly cost more than the QP solve itself.

`IKProblem` does the same arithmetic, operation for operation, into arrays it allocates once:
the same H, c, G and h reach the same `daqp.solve` call, so the velocity it returns is mink's,
bit for bit (tests/test_ik_qp.py holds it to `np.array_equal` against `mink.solve_ik`). It
knows the tasks and limits `IKSolver` builds (`FrameTask`, `NullspacePostureTask`,
`PostureTask`, `DampingTask`; `ConfigurationLimit` without ball joints, `VelocityLimit`);
`IKProblem.supports` says whether a task list is one of those, and the solver falls back to
`mink.solve_ik` when it is not.
"""

from __future__ import annotations

from collections.abc import Sequence
from ctypes import c_int

import daqp
import mink
import mujoco
import numpy as np

from .posture import NullspacePostureTask

__all__ = ["IKProblem"]

_NO_LOWER = -1e30
"""What qpsolvers' DAQP interface passes as the lower bound of a one-sided inequality."""


class IKProblem:
    """The differential-IK QP of fixed tasks and limits, solved with DAQP.

    Args:
        configuration: The solver's configuration (its model and data are read each call).
        tasks: The tasks, in mink's order (the order of the stacked residual rows).
        limits: The limits, in mink's order (the order of the stacked inequality rows).
        damping: Global Levenberg-Marquardt damping added to H's diagonal.

    Raises:
        ValueError: A task or limit this assembly does not know (check `supports` first).
    """

    def __init__(
        self,
        configuration: mink.Configuration,
        tasks: Sequence[mink.Task],
        limits: Sequence[mink.Limit],
        damping: float,
    ) -> None:
        if not self.supports(tasks, limits):
            raise ValueError(
                f"IKProblem assembles FrameTask, NullspacePostureTask, PostureTask, "
                f"DampingTask with ConfigurationLimit and VelocityLimit; got "
                f"{[type(t).__name__ for t in tasks]} and {[type(x).__name__ for x in limits]}"
            )
        self.configuration = configuration
        self.model = configuration.model
        self.tasks = list(tasks)
        self.limits = list(limits)
        self.damping = damping
        nv = self.model.nv
        self.rows: list[slice] = []
        start = 0
        for task in self.tasks:
            k = 6 if isinstance(task, mink.FrameTask) else nv
            self.rows.append(slice(start, start + k))
            start += k
        self._W = np.empty((start, nv))
        """The stacked cost-weighted task Jacobians. Shape (rows, nv)."""
        self._e = np.empty(start)
        """The stacked cost-weighted task errors. Shape (rows,)."""
        self._plan = [
            (_kind(task), task, self._e[rows], self._W[rows])
            for task, rows in zip(self.tasks, self.rows, strict=True)
        ]
        """Per task: its kind, itself, and its views of the stacked rows."""
        self._constant: list[tuple[bytes, float] | None] = [None] * len(self.tasks)
        """Per task: the (cost bits, gain) its rows were last written for, when they do not
        depend on the configuration (a posture task's Jacobian I, a damping task's rows)."""
        self._damping_sq = [0.0] * len(self.tasks)
        """Per damping task: its (constant) e·e of the last write."""
        self._velocity_h: list[tuple[float, bytes] | None] = [None] * len(self.limits)
        """Per velocity limit: the (dt, limit bits) its rows of h were last written for."""
        self._ones = [np.ones_like(task.cost).tobytes() for task in self.tasks]
        """Per task: the bits of a cost of all ones (its rows are then not multiplied)."""
        self._jacobian = [np.empty((rows.stop - rows.start, nv)) for rows in self.rows]
        """Per task: its Jacobian before the cost (used where the cost is not all ones)."""
        self._H = np.empty((nv, nv))
        self._c = np.empty(nv)
        self._H_diagonal = self._H.reshape(-1)[:: nv + 1]
        """A view of H's diagonal."""
        self._diff = np.empty(nv)
        self._posture_term = np.empty(nv)
        self._dq_max = np.empty(nv)
        self._dq_min = np.empty(nv)
        self._eye = np.eye(nv)
        blocks = [np.vstack([lim.projection_matrix, -lim.projection_matrix]) for lim in limits]
        self.G = np.vstack(blocks) if blocks else None
        """The limits' inequality matrix (constant: the limits are boxes). Shape (m, nv)."""
        m = 0 if self.G is None else self.G.shape[0]
        self._h = np.empty(m)
        self._h_rows: list[tuple[np.ndarray, np.ndarray]] = []
        """Per limit: its views of h's upper and lower rows."""
        at = 0
        for limit in self.limits:
            n = len(limit.indices)
            self._h_rows.append((self._h[at : at + n], self._h[at + n : at + 2 * n]))
            at += 2 * n
        self._lower = np.full(m, _NO_LOWER)
        self._sense = np.zeros(m, dtype=c_int)

    @staticmethod
    def supports(tasks: Sequence[mink.Task], limits: Sequence[mink.Limit]) -> bool:
        """Whether `IKProblem` can assemble these tasks and limits (else use mink.solve_ik)."""
        known_task = (mink.FrameTask, NullspacePostureTask, mink.PostureTask)
        frames = [t for t in tasks if isinstance(t, mink.FrameTask)]
        for task in tasks:
            if type(task) not in (*known_task, mink.DampingTask):
                return False
            if isinstance(task, mink.PostureTask) and task._v_ids is not None:
                return False  # floating-base columns zeroed: not assembled here
            if isinstance(task, NullspacePostureTask) and (
                len(frames) != 1
                or task.frame_task is not frames[0]
                or tasks.index(frames[0]) > tasks.index(task)
            ):
                return False  # its projector needs its frame task's Jacobian first
        for limit in limits:
            if type(limit) is mink.ConfigurationLimit:
                if limit.projection_matrix is None or len(limit._ball_qposadr) > 0:
                    return False
            elif type(limit) is not mink.VelocityLimit or limit.projection_matrix is None:
                return False
        return True

    def solve(self, dt: float) -> np.ndarray:
        """The tangent velocity [rad/s or m/s] over `dt` [s] that `mink.solve_ik(configuration,
        tasks, dt, "daqp", damping=damping, limits=limits)` returns. Shape (nv,).

        Raises:
            mink.NoSolutionFound: DAQP found no solution.
        """
        H, c = self._objective()
        h = self._inequalities(dt)
        if self.G is None:
            x, _, exitflag, _ = daqp.solve(
                H, c, np.zeros((0, c.size)), np.zeros(0), np.full(0, _NO_LOWER), self._sense
            )
        else:
            x, _, exitflag, _ = daqp.solve(H, c, self.G, h, self._lower, self._sense)
        if exitflag <= 0:
            raise mink.NoSolutionFound("daqp")
        v: np.ndarray = x / dt
        return v

    def _objective(self) -> tuple[np.ndarray, np.ndarray]:
        """H and c of mink's `_compute_qp_objective`, the same operations in place.

        A posture task's Jacobian rows (cost x I) and a damping task's rows (its error is
        zero) do not depend on the configuration: they are written again only when the
        task's cost or gain changed (compared bit for bit), not on every step."""
        config = self.configuration
        W, e = self._W, self._e
        mu_total = 0.0
        frame_jacobian = None
        for i, (kind, task, e_rows, w_rows) in enumerate(self._plan):
            # `==`, not `is`: a snapshot's restored plan holds its own copies of the strings
            if kind == _POSTURE:  # PostureTask, DampingTask: J = I, e = q - q* (DampingTask: 0)
                key = (task.cost.tobytes(), task.gain)
                fresh = key != self._constant[i]
                if fresh:
                    self._constant[i] = key
                    np.multiply(task.cost[:, None], self._eye, out=w_rows)
                if type(task) is mink.DampingTask:
                    if fresh:
                        np.multiply(task.cost, -task.gain * self._zero_error(), out=e_rows)
                        self._damping_sq[i] = float(e_rows @ e_rows)
                    mu_total += task.lm_damping * self._damping_sq[i]
                    continue
                error = self._posture_error(task)
                np.multiply(task.cost, -task.gain * error, out=e_rows)
                mu_total += task.lm_damping * float(e_rows @ e_rows)
                continue
            # a cost of exactly 1 (the frame task's, the nullspace posture's) multiplies by 1:
            # the Jacobian is then written straight into its rows of W, and cost x (-gain e)
            # is -gain e (the same numbers, two numpy calls fewer)
            unit = task.cost.tobytes() == self._ones[i]
            jacobian = w_rows if unit else self._jacobian[i]
            if kind == _FRAME:
                error, frame = task._error_and_jacobian(config)
                jacobian[:] = frame
                frame_jacobian = jacobian
            else:  # _NULLSPACE: its frame task comes first (`supports`)
                task.projector_from(frame_jacobian, out=jacobian)
                error = np.dot(jacobian, task.raw_error_view(config), out=self._posture_term)
            if unit:
                np.multiply(-task.gain, error, out=e_rows)
            else:
                np.multiply(task.cost, -task.gain * error, out=e_rows)
                np.multiply(task.cost[:, None], jacobian, out=w_rows)
            if task.lm_damping != 0.0:  # (0 x e·e adds nothing to mu)
                mu_total += task.lm_damping * float(np.dot(e_rows, e_rows))
        # H = WᵀW and c = -(eW) into arrays kept here (the same products), H's diagonal a
        # strided view of it: one ufunc call, where `H.flat[...] +=` goes through numpy's
        # flat iterator (the same additions). `np.dot`, not `@`: the same BLAS call on 2-D
        # arrays (the same bits, tests/test_ik_qp.py) without the generalized ufunc's
        # set-up, ~0.5 us a call
        H, c = self._H, self._c
        np.dot(W.T, W, out=H)
        np.dot(e, W, out=c)
        np.negative(c, out=c)
        self._H_diagonal += self.damping + mu_total
        return H, c

    def _zero_error(self) -> np.ndarray:
        """A damping task's error: zero. Shape (nv,)."""
        self._diff[:] = 0.0
        return self._diff

    def _posture_error(self, task: mink.PostureTask) -> np.ndarray:
        """A mink posture task's error, without its allocations."""
        if task.target_q is None:
            raise mink.TargetNotSet(type(task).__name__)
        mujoco.mj_differentiatePos(
            self.model, self._diff, 1.0, task.target_q, self.configuration.data.qpos
        )
        return self._diff

    def _inequalities(self, dt: float) -> np.ndarray:
        """h of mink's `_compute_qp_inequalities` (G is constant), into one array.

        A velocity limit's rows depend on `dt` only: written again when `dt` or the limit
        changed (the dry runs of time_scaling.py step at another dt than the control tick)."""
        qpos = self.configuration.data.qpos
        for i, limit in enumerate(self.limits):
            upper, lower = self._h_rows[i]
            if type(limit) is mink.ConfigurationLimit:  # gain (q_max - q), gain (q - q_min)
                mujoco.mj_differentiatePos(self.model, self._dq_max, 1.0, qpos, limit.upper)
                mujoco.mj_differentiatePos(self.model, self._dq_min, 1.0, limit.lower, qpos)
                self._dq_max.take(limit.indices, out=upper)
                upper *= limit.gain
                self._dq_min.take(limit.indices, out=lower)
                lower *= limit.gain
            else:  # VelocityLimit: dt v_max both ways
                key = (dt, limit.limit.tobytes())
                if key != self._velocity_h[i]:
                    self._velocity_h[i] = key
                    np.multiply(dt, limit.limit, out=upper)
                    lower[:] = upper
        return self._h


_FRAME, _NULLSPACE, _POSTURE = "frame", "nullspace", "posture"


def _kind(task: mink.Task) -> str:
    """How `IKProblem` assembles `task`'s rows."""
    if isinstance(task, mink.FrameTask):
        return _FRAME
    if isinstance(task, NullspacePostureTask):
        return _NULLSPACE
    return _POSTURE
