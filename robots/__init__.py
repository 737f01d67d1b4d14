"""Robot models and the low-level controller (installed as `orchestrator.robots`)."""

from .base import Gains, Robot
from .controller import Controller, ControlMode
from .exceptions import RobotError
from .mobile import MobilePanda
from .panda import Panda

ROBOTS: dict[str, type[Robot]] = {Panda.name: Panda, MobilePanda.name: MobilePanda}


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
    "get_robot",
]
