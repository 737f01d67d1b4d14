"""Registration by touch, the estimation: the phantom's pose from static touches of its surface.

Each touch presses the probe's ball tip (radius `r`) against the phantom — on its top face or
on an edge of the top — and holds it still at a few force levels; each level gives the ball's
centre `c` (the controller's forward kinematics) and the wrist force `F`. Soft tissue yields,
so the ball sits deeper than where the surface is: with the tissue's registered force law `L`
(its shape; the true tissue is that law scaled by an unknown factor `s`) and `D` the distance
from the ball's centre to the phantom's box (zero on its surface), the contact pushes back
along the box's outward normal `m` at `c` with

    F . m = s L(r - D(R^T (c - t))).

`fit_touches` finds the pose (rotation `R`, position `t` of the phantom's surface frame) and
`s` that explain every level of every touch (weighted least squares, Gauss-Newton on
`R exp(dtheta)`, `t + dt`, `s`; numerical derivatives), with their covariance.
`lateral_sigma` is the 1-sigma error that covariance puts on a point of the phantom frame
mapped into the world, along a direction.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

__all__ = ["Touch", "TouchFit", "box_distance", "fit_touches", "lateral_sigma"]

_STEP = 1e-7
"""Step of the numerical derivatives [m, rad, 1]."""


@dataclass(frozen=True)
class Touch:
    """One touch: per force level, where the ball's centre was and what the wrist felt.

    Attributes:
        centres: Ball centre in the world [m], per level. Shape (k, 3).
        forces: Mean wrist force (external, on the tool) in the world [N], per level. Shape
            (k, 3).
        sigma_n: Standard error of each mean force [N] (> 0). Shape (k,).
    """

    centres: np.ndarray
    forces: np.ndarray
    sigma_n: np.ndarray


@dataclass(frozen=True)
class TouchFit:
    """The phantom's pose and the tissue's scale fitted to the touches.

    Attributes:
        rotation: Orientation of its surface frame in the world. Shape (3, 3).
        position: Origin of its surface frame (top-surface centre) in the world [m]. Shape (3,).
        scale: The true law over the registered one.
        covariance: Of (dt [m], dtheta [rad] about the frame's own axes, scale). Shape (7, 7).
        rms_n: RMS of the force residuals [N].
        indentation_m: Fitted indentation of every level, touch by touch [m].
    """

    rotation: np.ndarray
    position: np.ndarray
    scale: float
    covariance: np.ndarray
    rms_n: float
    indentation_m: list[np.ndarray]


def box_distance(q: np.ndarray, size: np.ndarray) -> tuple[float, np.ndarray]:
    """Distance [m] of the point `q` (surface frame, shape (3,)) from the phantom's box (its
    top-surface centre at the origin, z up; negative inside) and the box's outward normal at
    the nearest point (shape (3,))."""
    half = np.asarray(size, dtype=float) / 2.0
    p = np.array([q[0], q[1], q[2] + half[2]])
    d = np.abs(p) - half
    out = np.maximum(d, 0.0)
    norm = float(np.linalg.norm(out))
    if norm > 0.0:
        return norm, np.sign(p) * out / norm
    i = int(np.argmax(d))
    normal = np.zeros(3)
    normal[i] = np.sign(p[i]) or 1.0
    return float(d[i]), normal


def fit_touches(
    touches: Sequence[Touch],
    size: np.ndarray,
    radius_m: float,
    law: Callable[[float], float],
    rotation: np.ndarray,
    position: np.ndarray,
    iterations: int = 30,
) -> TouchFit:
    """Fit the pose and the law's scale to the touches.

    Args:
        touches: At least 6 levels over touches that constrain all six degrees of freedom
            (e.g. 3 on the top, 2 on a long edge, 1 on an end edge).
        size: The phantom's edge lengths [m]. Shape (3,).
        radius_m: The ball tip's radius [m].
        law: The registered force law at rest: force [N] of an indentation [m] (0 outside).
        rotation: Initial orientation (the prior estimate). Shape (3, 3).
        position: Initial position [m]. Shape (3,).
        iterations: Gauss-Newton iterations at most.

    Raises:
        ValueError: If the touches leave a degree of freedom undetermined.
    """
    rot = np.array(rotation, dtype=float)
    pos = np.array(position, dtype=float)
    scale = 1.0
    sigma = np.concatenate([t.sigma_n for t in touches])
    k0 = law(_STEP) / _STEP  # the law's stiffness at the surface [N/m]

    def pushing(x: float) -> float:
        """The law, continued through the surface as a spring that pulls: from a prior a few
        millimetres off, a touch the pose puts outside the surface still says which way to
        move (the real law's zero force would drop it from the fit)."""
        return law(x) if x > 0.0 else k0 * x

    def residuals(r: np.ndarray, t: np.ndarray, s: float) -> np.ndarray:
        out = []
        for touch in touches:
            for c, f in zip(touch.centres, touch.forces, strict=True):
                dist, normal = box_distance(r.T @ (c - t), size)
                out.append(float(f @ (r @ normal)) - s * pushing(radius_m - dist))
        return np.array(out) / sigma

    res = residuals(rot, pos, scale)
    jac = np.zeros((len(res), 7))
    for _ in range(iterations):
        for k in range(7):
            delta = np.zeros(7)
            delta[k] = _STEP
            jac[:, k] = (residuals(*_moved(rot, pos, scale, delta)) - res) / _STEP
        if np.linalg.matrix_rank(jac, tol=1e-9 * float(np.abs(jac).max())) < 7:
            raise ValueError(f"{len(touches)} touches leave the phantom's pose undetermined")
        step, *_ = np.linalg.lstsq(jac, -res, rcond=None)
        rot, pos, scale = _moved(rot, pos, scale, step)
        res = residuals(rot, pos, scale)
        if float(np.max(np.abs(step))) < 1e-11:
            break
    dof = max(len(res) - 7, 1)
    chi2 = float(res @ res) / dof
    indentation = [
        np.array([radius_m - box_distance(rot.T @ (c - pos), size)[0] for c in t.centres])
        for t in touches
    ]
    return TouchFit(
        rotation=rot,
        position=pos,
        scale=scale,
        covariance=np.linalg.inv(jac.T @ jac) * max(chi2, 1.0),
        rms_n=float(np.sqrt(np.mean((res * sigma) ** 2))),
        indentation_m=indentation,
    )


def _moved(
    rot: np.ndarray, pos: np.ndarray, scale: float, delta: np.ndarray
) -> tuple[np.ndarray, np.ndarray, float]:
    """The pose and scale moved by `delta` (dt [m], dtheta [rad] about the frame's axes,
    dscale; shape (7,))."""
    return rot @ _exp(delta[3:6]), pos + delta[:3], scale + float(delta[6])


def lateral_sigma(fit: TouchFit, local: np.ndarray, direction: np.ndarray) -> float:
    """1-sigma error [m] along `direction` (world, unit, shape (3,)) of the phantom-frame point
    `local` (shape (3,)) mapped into the world by the fitted pose."""
    skew = np.array(
        [[0.0, -local[2], local[1]], [local[2], 0.0, -local[0]], [-local[1], local[0], 0.0]]
    )
    g = np.concatenate([direction, -(direction @ fit.rotation @ skew), [0.0]])
    return float(np.sqrt(max(g @ fit.covariance @ g, 0.0)))


def _exp(w: np.ndarray) -> np.ndarray:
    """Rotation matrix of the rotation vector `w` [rad] (Rodrigues). Shape (3, 3)."""
    angle = float(np.linalg.norm(w))
    if angle < 1e-15:
        return np.eye(3)
    k = w / angle
    skew = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) + np.sin(angle) * skew + (1.0 - np.cos(angle)) * skew @ skew
