"""Helpers shared by the gripper skills: what the fingers press on.

A gripper knows what it holds by its fingers, not by a name: the fingers stopped short of
closed, both pads pressing on one body. `held_object` reads that from the contacts, whichever
scene object it is; a flow that expects a particular one compares the name afterwards.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from orchestrator.engine.context import Context

__all__ = [
    "ANY_OBJECT",
    "finger_contact_forces",
    "finger_forces",
    "gripped_object",
    "grasped_height",
    "held_object",
    "note_grasp",
]

ANY_OBJECT = "*"
"""`object: "*"`: whichever scene object the fingers close on."""


def finger_forces(ctx: Context) -> dict[int, list[float]]:
    """Body id -> normal contact force [N] of the left and the right finger on it, for every
    body the fingers touch (the robot's own bodies left out)."""
    import mujoco

    m, d, w = ctx.model, ctx.data, ctx.world
    left, right = w.finger_body_ids
    robot = w.robot_geoms
    out: dict[int, list[float]] = {}
    wrench = np.zeros(6)
    for i in range(d.ncon):
        con = d.contact[i]
        g1, g2 = int(con.geom1), int(con.geom2)
        b1, b2 = int(m.geom_bodyid[g1]), int(m.geom_bodyid[g2])
        if b1 in (left, right) and g2 not in robot:
            finger, other = b1, b2
        elif b2 in (left, right) and g1 not in robot:
            finger, other = b2, b1
        else:
            continue
        mujoco.mj_contactForce(m, d, i, wrench)
        forces = out.setdefault(other, [0.0, 0.0])
        forces[0 if finger == left else 1] += abs(float(wrench[0]))
    return out


def finger_contact_forces(ctx: Context, object_geom: int) -> tuple[float, float]:
    """Normal contact force [N] of the left and the right finger on the body of
    `object_geom`."""
    left, right = finger_forces(ctx).get(int(ctx.model.geom_bodyid[object_geom]), (0.0, 0.0))
    return left, right


def held_object(ctx: Context) -> tuple[str | None, float, float]:
    """The scene object both fingers press on hardest (the weaker finger's force decides),
    with the left and right finger's forces [N]; `(None, 0, 0)` when no scene object touches
    both fingers."""
    forces = finger_forces(ctx)
    best, best_lr = None, (0.0, 0.0)
    for name, handle in ctx.world.objects.items():
        lr = forces.get(handle.body_id)
        if lr is not None and min(lr) > min(best_lr):
            best, best_lr = name, (lr[0], lr[1])
    return best, best_lr[0], best_lr[1]


def gripped_object(ctx: Context, name: str) -> str | None:
    """`name`, or for `ANY_OBJECT` the scene object both fingers press on hardest (None when
    no object touches both)."""
    if name != ANY_OBJECT:
        return name
    return held_object(ctx)[0]


def note_grasp(ctx: Context, name: str) -> None:
    """Remember where `name` was when the fingers closed on it (`ctx.grasped_at`)."""
    ctx.grasped_at[name] = float(ctx.object_pose(name).pos[2])


def grasped_height(ctx: Context, name: str) -> float | None:
    """The height [m] of `name`'s centre when the fingers last closed on it (None: never in
    this episode): what a lift is measured from, wherever the object had been moved to."""
    return ctx.grasped_at.get(name)
