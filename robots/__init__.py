"""Robot models and the low-level controller (installed as `orchestrator.robots`).

The robot classes are declarations (joint names, gains, reach) the validator reads: their
modules import MuJoCo and pinocchio inside the methods that build models. The controller
(pinocchio at its top) is imported on first use of `Controller` or `ControlMode`.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from .base import Gains, Robot
from .exceptions import RobotError
from .mobile import MobilePanda
from .panda import Panda
from .so101 import SO101
from .ur5 import UR5

if TYPE_CHECKING:
    from .controller import Controller, ControlMode

ROBOTS: dict[str, type[Robot]] = {
    Panda.name: Panda,
    MobilePanda.name: MobilePanda,
    UR5.name: UR5,
    SO101.name: SO101,
}


def __getattr__(name: str) -> Any:
    if name not in ("Controller", "ControlMode"):
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(importlib.import_module(".controller", __name__), name)


def get_robot(name: str) -> Robot:
    """Instantiate a registered robot by name."""
    try:
        return ROBOTS[name]()
    except KeyError:
        raise RobotError(f"unknown robot {name!r} (valid: {', '.join(sorted(ROBOTS))})") from None


__all__ = [
    "ROBOTS",
    "ControlMode",
    "Controller",
    "Gains",
    "MobilePanda",
    "Panda",
    "Robot",
    "RobotError",
    "SO101",
    "UR5",
    "get_robot",
]
