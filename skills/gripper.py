"""Helpers shared by the gripper skills: contacts between the fingers and an object."""

from __future__ import annotations

from typing import TYPE_CHECKING

import mujoco
import numpy as np

if TYPE_CHECKING:
    from orchestrator.engine.context import Context

__all__ = ["ANY_OBJECT", "finger_contact_forces", "gripped_object"]

ANY_OBJECT = "*"
"""`object: "*"`: whichever scene object the fingers press on."""


def finger_contact_forces(ctx: Context, object_geom: int) -> tuple[float, float]:
    """Normal contact force [N] of the left and the right finger on `object_geom`."""
    m, d, w = ctx.model, ctx.data, ctx.world
    left, right = w.finger_body_ids
    out = [0.0, 0.0]
    wrench = np.zeros(6)
    for i in range(d.ncon):
        con = d.contact[i]
        g1, g2 = con.geom1, con.geom2
        if object_geom not in (g1, g2):
            continue
        other = g2 if g1 == object_geom else g1
        body = m.geom_bodyid[other]
        if body not in (left, right):
            continue
        mujoco.mj_contactForce(m, d, i, wrench)
        out[0 if body == left else 1] += abs(float(wrench[0]))
    return out[0], out[1]


def gripped_object(ctx: Context, name: str) -> str | None:
    """`name`, or for `ANY_OBJECT` the scene object both fingers press on hardest (the weaker
    finger's force decides; None when no object touches both)."""
    if name != ANY_OBJECT:
        return name
    best, best_force = None, 0.0
    for obj, handle in ctx.world.objects.items():
        left, right = finger_contact_forces(ctx, handle.geom_id)
        if min(left, right) > best_force:
            best, best_force = obj, min(left, right)
    return best
