"""Built-in guards, by name."""

from __future__ import annotations

from ..exceptions import OrchestratorError
from .base import Guard
from .collision import Collision
from .contact_force import ContactForce
from .grasp_lost import GraspLost
from .joint_acceleration import JointAcceleration
from .joint_limits import JointLimits
from .joint_torque import JointTorque
from .joint_velocity import JointVelocity
from .no_go_zone import NoGoZone
from .path_deviation import PathDeviation
from .sensor_health import SensorHealth
from .workspace import Workspace

GUARDS: dict[str, type[Guard]] = {
    g.name: g
    for g in (
        JointLimits,
        Workspace,
        ContactForce,
        NoGoZone,
        PathDeviation,
        SensorHealth,
        Collision,
        JointVelocity,
        JointAcceleration,
        JointTorque,
        GraspLost,
    )
}


def bundled_guards() -> dict[str, type[Guard]]:
    """The guards this package ships, by name: `GUARDS` without one a plugin or a test
    registered in the process (what the shipped schemas and docs/skills.md list)."""
    return {
        name: cls
        for name, cls in sorted(GUARDS.items())
        if cls.__module__.startswith("orchestrator.guards.")
    }


class UnknownGuardError(OrchestratorError):
    """No guard of that name."""


def get_guard(name: str) -> type[Guard]:
    """The guard class registered as `name`."""
    try:
        return GUARDS[name]
    except KeyError:
        raise UnknownGuardError(
            f"unknown guard {name!r} (valid: {', '.join(sorted(GUARDS))})"
        ) from None


__all__ = [
    "GUARDS",
    "Collision",
    "ContactForce",
    "GraspLost",
    "JointAcceleration",
    "JointTorque",
    "JointVelocity",
    "SensorHealth",
    "JointLimits",
    "NoGoZone",
    "PathDeviation",
    "UnknownGuardError",
    "Workspace",
    "get_guard",
]
