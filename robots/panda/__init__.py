"""Franka Emika Panda."""

from .model import Panda, panda_urdf_path

__all__ = ["Panda", "panda_urdf_path"]
