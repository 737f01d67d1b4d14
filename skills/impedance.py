"""Cartesian impedance commands in the world frame, shared by the contact-rich skills.

Not a skill: `contact`, `register`, `hold` and `retract` use it to talk to the controller's
Cartesian impedance mode, whose setpoints live in the robot's base frame and whose stiffness
is diagonal in a frame of the skill's choosing (a surface's normal and tangents, or the base
axes).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from orchestrator.robots.controller import CartesianGains

    from orchestrator.engine.context import Context

__all__ = [
    "APPARENT_INERTIA",
    "APPARENT_MASS_KG",
    "aligned",
    "command",
    "frame_with_z",
    "gains",
    "measured_tcp",
    "setpoint",
    "translational_stiffness",
]

APPARENT_MASS_KG = 6.0
"""Translational inertia the arm shows at the tool tip in the surgical postures [kg] (the
Panda's with rotor inertia); the damping below is sized for it."""
APPARENT_INERTIA = 0.3
"""Rotational inertia at the tip [kg m^2], for the rotational damping."""


def gains(
    stiffness_n_per_m: np.ndarray | float,
    rotational_nm_per_rad: float,
    damping_ratio: float = 1.0,
    nullspace_stiffness: float = 10.0,
    frame: np.ndarray | None = None,
) -> CartesianGains:
    """Impedance gains with damping `2 zeta sqrt(K m)` for the arm's apparent inertia.

    Args:
        stiffness_n_per_m: Translational stiffness along the axes of `frame` [N/m]: shape
            (3,), or one value for all three.
        rotational_nm_per_rad: Rotational stiffness [Nm/rad].
        damping_ratio: zeta, 1 for critical damping.
        nullspace_stiffness: Posture stiffness in the task's nullspace [Nm/rad].
        frame: Rotation whose columns are the gains' axes in the world, shape (3, 3) (e.g. a
            surface's two tangents and its normal); None: the world axes.
    """
    from orchestrator.robots.controller import CartesianGains

    k_t = np.broadcast_to(np.asarray(stiffness_n_per_m, dtype=float), (3,))
    k = np.concatenate([k_t, np.full(3, float(rotational_nm_per_rad))])
    m = np.array([APPARENT_MASS_KG] * 3 + [APPARENT_INERTIA] * 3)
    return CartesianGains(
        stiffness=k,
        damping=2.0 * damping_ratio * np.sqrt(k * m),
        nullspace_stiffness=nullspace_stiffness,
        frame=None if frame is None else np.array(frame, dtype=float).reshape(3, 3),
    )


def translational_stiffness(impedance: CartesianGains) -> np.ndarray:
    """The translational stiffness matrix in the world, `R diag(k) R^T` [N/m]. Shape (3, 3)."""
    k = np.diag(impedance.stiffness[:3])
    r = impedance.frame
    return k if r is None else r @ k @ r.T


def setpoint(ctx: Context, new: CartesianGains | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Where a skill taking over should put the setpoint to hold the arm as it is held now.

    In Cartesian mode that is the current setpoint, moved so that the `new` gains' stiffness
    (default: unchanged) pushes with the same force, whatever the axes of either: a contact
    preload carries over without a step. Otherwise it is the TCP pose as the controller's
    model puts it (`measured_tcp`).

    Returns:
        Position [m] in the world, shape (3,), and rotation, shape (3, 3), both copies.
    """
    from orchestrator.robots.controller import ControlMode

    ctrl = ctx.controller
    if ctrl.mode is not ControlMode.CARTESIAN:
        return measured_tcp(ctx)
    pos = ctrl.pos_d + _base(ctx)
    if new is not None:
        tcp, _ = measured_tcp(ctx)
        force = translational_stiffness(ctrl.cart) @ (pos - tcp)
        pos = tcp + np.linalg.solve(translational_stiffness(new), force)
    return pos, ctrl.rot_d.copy()


def measured_tcp(ctx: Context) -> tuple[np.ndarray, np.ndarray]:
    """The TCP pose by the controller's own model at the encoder readings: position [m] in the
    world, shape (3,), and rotation, shape (3, 3) (copies). What the robot itself knows of
    where its tool is, as opposed to the simulator's ground truth (`ctx.tcp_pos`)."""
    q, _ = ctx.robot_q()
    pos, rot = ctx.controller.tcp_pose(q)
    return pos + _base(ctx), rot


def command(
    ctx: Context,
    pos: np.ndarray,
    rot: np.ndarray,
    impedance: CartesianGains,
    q_null: np.ndarray | None = None,
) -> None:
    """Cartesian impedance about the world pose (`pos` [m] shape (3,), `rot` shape (3, 3))."""
    ctx.controller.set_cartesian_target(np.asarray(pos) - _base(ctx), rot, impedance, q_null)


def _base(ctx: Context) -> np.ndarray:
    return np.asarray(ctx.scenario.robot.base_pos, dtype=float)


def frame_with_z(z: np.ndarray) -> np.ndarray:
    """A rotation whose third column is the unit vector `z` (shape (3,)): the axes of gains
    stiff or compliant along `z` and alike across it. Shape (3, 3)."""
    z = np.asarray(z, dtype=float)
    helper = np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = helper - float(helper @ z) * z
    x /= np.linalg.norm(x)
    return np.column_stack([x, np.cross(z, x), z])


def aligned(rot: np.ndarray, axis: np.ndarray) -> np.ndarray:
    """`rot` (shape (3, 3)) turned the least (about an axis through the TCP) so that its z
    axis — the tool's — points along the unit vector `axis`."""
    z = rot[:, 2]
    w = np.cross(z, axis)
    s, c = float(np.linalg.norm(w)), float(z @ axis)
    if s < 1e-12:
        return np.array(rot, dtype=float)
    k = w / s
    skew = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return (np.eye(3) + s * skew + (1.0 - c) * skew @ skew) @ rot
