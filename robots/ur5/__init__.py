"""Universal Robots UR5 with a Robotiq 2F-85-class parallel gripper."""

from .model import UR5, ur5_urdf

__all__ = ["UR5", "ur5_urdf"]
