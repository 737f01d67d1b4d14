"""Built-in guards, by name."""

from __future__ import annotations

from ..exceptions import OrchestratorError
from .base import Guard
from .contact_force import ContactForce
from .joint_limits import JointLimits
from .no_go_zone import NoGoZone
from .path_deviation import PathDeviation
from .workspace import Workspace

GUARDS: dict[str, type[Guard]] = {
    g.name: g for g in (JointLimits, Workspace, ContactForce, NoGoZone, PathDeviation)
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
    "ContactForce",
    "JointLimits",
    "NoGoZone",
    "PathDeviation",
    "UnknownGuardError",
    "Workspace",
    "get_guard",
]
