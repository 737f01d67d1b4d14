"""The body: the MuJoCo world built from a scenario (robot, scene, randomization), poses."""

from .path import PlannedPath
from .phantom import PhantomHandle
from .pose import Pose, quat_from_yaw, yaw_of
from .world import ObjectHandle, World, as_index, robot_only_model

__all__ = [
    "ObjectHandle",
    "PhantomHandle",
    "PlannedPath",
    "Pose",
    "World",
    "as_index",
    "quat_from_yaw",
    "robot_only_model",
    "yaw_of",
]
