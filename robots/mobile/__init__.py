"""Mobile manipulators."""

from .model import BASE, BaseGeometry, MobilePanda, mobile_panda_urdf

__all__ = ["BASE", "BaseGeometry", "MobilePanda", "mobile_panda_urdf"]
