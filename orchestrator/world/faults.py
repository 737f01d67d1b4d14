"""Faults of the world itself: an obstacle that appears, a grip that slips, a push.

Obstacles must exist when the model is compiled, so `add_fault_obstacles` adds each one
hidden (no collision, transparent) and `FaultEffects.show_obstacle` makes it appear.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import mujoco
import numpy as np

from ..robots.panda.model import WORLD_CONAFFINITY, WORLD_CONTYPE

if TYPE_CHECKING:
    from ..language.scenario import Scenario

__all__ = ["OBSTACLE_RGBA", "FaultEffects", "add_fault_obstacles", "fault_obstacle_name"]

OBSTACLE_RGBA = (0.95, 0.55, 0.1, 1.0)
"""Colour of an obstacle once it has appeared."""
HIDDEN_CONTYPE = 32
"""Collision bit of an obstacle that has not appeared yet (no geom has it as affinity)."""


def fault_obstacle_name(index: int) -> str:
    """Geom name of the obstacle of fault number `index` in the scenario's `faults:`."""
    return f"fault_obstacle_{index}"


def add_fault_obstacles(spec: mujoco.MjSpec, scenario: Scenario) -> None:
    """A hidden box for every `obstacle` fault (no collision, transparent, until it appears)."""
    for i, fault in enumerate(scenario.faults):
        if fault.kind != "obstacle":
            continue
        g = spec.worldbody.add_geom(
            name=fault_obstacle_name(i),
            type=mujoco.mjtGeom.mjGEOM_BOX,
            pos=list(fault.pos),
            size=[s / 2.0 for s in fault.size],
        )
        # A collision bit no geom has an affinity for: with no bits at all, MuJoCo leaves the
        # geom out of collision detection for good, and it could never appear.
        g.contype, g.conaffinity = HIDDEN_CONTYPE, 0
        g.rgba = [*OBSTACLE_RGBA[:3], 0.0]


class FaultEffects:
    """Changes a running world as faults require.

    Args:
        model: The episode's model (faults change it: each episode compiles its own).
        data: The episode's data.
        object_bodies: Scene object name -> (body id, geom id).
        finger_geoms: Geoms of the gripper's fingers.
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        data: mujoco.MjData,
        object_bodies: dict[str, tuple[int, int]],
        finger_geoms: frozenset[int],
    ) -> None:
        self.model, self.data = model, data
        self.object_bodies = object_bodies
        self.finger_geoms = finger_geoms

    def show_obstacle(self, index: int) -> None:
        """The obstacle of fault `index` appears: it collides and is drawn."""
        m = self.model
        g = m.geom(fault_obstacle_name(index)).id
        m.geom_contype[g], m.geom_conaffinity[g] = WORLD_CONTYPE, WORLD_CONAFFINITY
        m.geom_rgba[g] = OBSTACLE_RGBA

    def slip(self, obj: str, factor: float) -> None:
        """Friction of the fingers and of `obj` x `factor` (their contact uses the larger)."""
        for g in (*self.finger_geoms, self.object_bodies[obj][1]):
            self.model.geom_friction[g, 0] *= factor

    def push(self, obj: str, force_n: np.ndarray) -> None:
        """Apply `force_n` (world frame [N]) at the centre of `obj` until `end_push`."""
        self.data.xfrc_applied[self.object_bodies[obj][0], :3] += force_n

    def end_push(self, obj: str, force_n: np.ndarray) -> None:
        """Take the force of `push` off again."""
        self.data.xfrc_applied[self.object_bodies[obj][0], :3] -= force_n
