"""A rigid pose value that lives on the blackboard and in YAML."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

__all__ = ["Pose", "quat_from_yaw", "quat_from_ypr", "rotation_of", "yaw_of"]


def quat_from_yaw(yaw_rad: float) -> np.ndarray:
    """Quaternion (w, x, y, z) of a rotation about world z by `yaw_rad` [rad]."""
    return np.array([math.cos(yaw_rad / 2), 0.0, 0.0, math.sin(yaw_rad / 2)])


def quat_from_ypr(yaw_rad: float, pitch_rad: float, roll_rad: float) -> np.ndarray:
    """Quaternion (w, x, y, z) of Rz(yaw) Ry(pitch) Rx(roll) [rad]: turned about world z, then
    tilted about its own y, then its own x."""
    cy, sy = math.cos(yaw_rad / 2), math.sin(yaw_rad / 2)
    cp, sp = math.cos(pitch_rad / 2), math.sin(pitch_rad / 2)
    cr, sr = math.cos(roll_rad / 2), math.sin(roll_rad / 2)
    return np.array(
        [
            cy * cp * cr + sy * sp * sr,
            cy * cp * sr - sy * sp * cr,
            cy * sp * cr + sy * cp * sr,
            sy * cp * cr - cy * sp * sr,
        ]
    )


def rotation_of(quat: Any) -> np.ndarray:
    """Rotation matrix (shape (3, 3)) of a quaternion (w, x, y, z), normalised first."""
    q = np.asarray(quat, dtype=float)
    w, x, y, z = q / np.linalg.norm(q)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


def yaw_of(quat: np.ndarray) -> float:
    """Yaw [rad] of a quaternion (w, x, y, z): the heading of its x axis in the world xy plane."""
    w, x, y, z = quat
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


class Pose(BaseModel):
    """Position [m] and orientation (quaternion w, x, y, z) in the world frame."""

    model_config = ConfigDict(defer_build=True, frozen=True, extra="forbid", allow_inf_nan=False)

    pos: list[float] = Field(min_length=3, max_length=3)
    """Position in the world frame [m]: `[x, y, z]`."""
    quat: list[float] = Field(
        default_factory=lambda: [1.0, 0.0, 0.0, 0.0], min_length=4, max_length=4
    )
    """Orientation, a unit quaternion `[w, x, y, z]` (default: the world's axes)."""

    @property
    def yaw(self) -> float:
        """Heading of the pose's x axis in [rad]."""
        return yaw_of(np.asarray(self.quat))

    @classmethod
    def coerce(cls, value: Any) -> Pose:
        """A Pose from a Pose, a `{pos, quat}` mapping or a 3-vector."""
        if isinstance(value, Pose):
            return value
        if isinstance(value, dict):
            return cls.model_validate(value)
        return cls(pos=[float(v) for v in value])
