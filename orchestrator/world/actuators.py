"""Actuator faults: a joint's motor that saturates early or delivers nothing."""

from __future__ import annotations

import numpy as np

__all__ = ["ActuatorFault"]


class ActuatorFault:
    """What one joint's motor really delivers of the torques the controller commands.

    The joint's torque sensor (the Panda has one in every joint) measures what the motor
    delivers, not what was commanded: `sensor_health` compares the two.

    Args:
        kind: `actuator_saturate` (at most `fraction` of the limit) or `actuator_lost` (none).
        joint: Arm joint, 0-based.
        limit_nm: That joint's torque limit [Nm].
        fraction: For `actuator_saturate`, the fraction of the limit it still delivers.
    """

    def __init__(self, kind: str, joint: int, limit_nm: float, fraction: float = 0.0) -> None:
        self.kind, self.joint = kind, joint
        self.cap = 0.0 if kind == "actuator_lost" else fraction * limit_nm
        self._out: np.ndarray | None = None

    def apply(self, tau: np.ndarray) -> np.ndarray:
        """Delivered torques [Nm] for commanded `tau` (shape (n_arm,)); `tau` is not changed."""
        if self._out is None:
            self._out = np.empty_like(tau)
        out = self._out
        out[:] = tau
        j = self.joint
        out[j] = min(max(out[j], -self.cap), self.cap)
        return out
