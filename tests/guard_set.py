"""The guard set the guard-bank tests check: pick_place's guards while it carries the cube."""

from __future__ import annotations

from orchestrator.engine.context import Context
from orchestrator.guards import (
    Collision,
    ContactForce,
    GraspLost,
    JointAcceleration,
    JointLimits,
    JointTorque,
    JointVelocity,
    SensorHealth,
    Workspace,
)
from orchestrator.guards.base import Guard


def carrying_guards(ctx: Context, max_force_n: float = 60.0) -> list[Guard]:
    """pick_place's guards while it carries the cube, bound and active, highest priority
    first; `max_force_n` is the contact-force limit [N]."""
    made = []
    for cls, params in (
        (Collision, {}),
        (SensorHealth, {}),
        (JointVelocity, {}),
        (JointAcceleration, {}),
        (JointTorque, {"duration_ms": 6.0}),
        (Workspace, {"min": [0.05, -0.6, 0.15], "max": [0.95, 0.6, 1.2]}),
        (ContactForce, {"max_n": max_force_n}),
        (JointLimits, {}),
        (GraspLost, {}),
    ):
        guard = cls(cls.Params.model_validate(params))
        guard.bind(ctx)
        guard.activate(ctx)
        made.append(guard)
    return sorted(made, key=lambda g: -g.priority)
