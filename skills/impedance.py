"""Cartesian impedance commands in the world frame, shared by the contact-rich skills.

Not a skill: `contact`, `hold` and `retract` use it to talk to the controller's Cartesian
impedance mode, whose setpoints live in the robot's base frame and whose stiffness is diagonal
in the base axes.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from orchestrator.robots.controller import CartesianGains, ControlMode

if TYPE_CHECKING:
    from orchestrator.engine.context import Context

__all__ = ["APPARENT_INERTIA", "APPARENT_MASS_KG", "command", "gains", "setpoint"]

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
) -> CartesianGains:
    """Impedance gains with damping `2 zeta sqrt(K m)` for the arm's apparent inertia.

    Args:
        stiffness_n_per_m: Translational stiffness along world x, y, z [N/m]: shape (3,), or
            one value for all three.
        rotational_nm_per_rad: Rotational stiffness [Nm/rad].
        damping_ratio: zeta, 1 for critical damping.
        nullspace_stiffness: Posture stiffness in the task's nullspace [Nm/rad].
    """
    k_t = np.broadcast_to(np.asarray(stiffness_n_per_m, dtype=float), (3,))
    k = np.concatenate([k_t, np.full(3, float(rotational_nm_per_rad))])
    m = np.array([APPARENT_MASS_KG] * 3 + [APPARENT_INERTIA] * 3)
    return CartesianGains(
        stiffness=k,
        damping=2.0 * damping_ratio * np.sqrt(k * m),
        nullspace_stiffness=nullspace_stiffness,
    )


def setpoint(
    ctx: Context, stiffness_n_per_m: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Where a skill taking over should put the setpoint to hold the arm as it is held now.

    In Cartesian mode that is the current setpoint, moved so that the new translational
    `stiffness_n_per_m` (shape (3,); default: unchanged) pushes with the same force: a contact
    preload carries over without a step. Otherwise it is the measured TCP pose.

    Returns:
        Position [m] in the world, shape (3,), and rotation, shape (3, 3), both copies.
    """
    ctrl = ctx.controller
    if ctrl.mode is not ControlMode.CARTESIAN:
        return ctx.tcp_pos.copy(), ctx.tcp_rot.copy()
    pos = ctrl.pos_d + _base(ctx)
    if stiffness_n_per_m is not None:
        tcp = ctx.tcp_pos
        pos = tcp + ctrl.cart.stiffness[:3] / np.asarray(stiffness_n_per_m) * (pos - tcp)
    return pos, ctrl.rot_d.copy()


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
