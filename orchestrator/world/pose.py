"""A rigid pose value that lives on the blackboard and in YAML."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

__all__ = ["Pose", "quat_from_yaw", "yaw_of"]


def quat_from_yaw(yaw_rad: float) -> np.ndarray:
    """Quaternion (w, x, y, z) of a rotation about world z by `yaw_rad` [rad]."""
    return np.array([math.cos(yaw_rad / 2), 0.0, 0.0, math.sin(yaw_rad / 2)])


def yaw_of(quat: np.ndarray) -> float:
    """Yaw [rad] of a quaternion (w, x, y, z): the heading of its x axis in the world xy plane."""
    w, x, y, z = quat
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


class Pose(BaseModel):
    """Position [m] and orientation (quaternion w, x, y, z) in the world frame."""

    model_config = ConfigDict(frozen=True, extra="forbid", allow_inf_nan=False)

    pos: list[float] = Field(min_length=3, max_length=3)
    quat: list[float] = Field(
        default_factory=lambda: [1.0, 0.0, 0.0, 0.0], min_length=4, max_length=4
    )

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
