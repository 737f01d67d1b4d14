"""The SO-101 (TheRobotStudio / Hugging Face LeRobot) with its own revolute jaw."""

from .model import SO101, so101_urdf

__all__ = ["SO101", "so101_urdf"]
