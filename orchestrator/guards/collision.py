"""`collision`: the robot touches nothing it is not meant to touch.

Read from the world's contact sensors (world/contacts.py), counted by MuJoCo during the step:
the guard reads one small block of numbers per physics step. A collision is any contact of

* a link or the hand with anything (the scene, or another link: each link carries a
  self-collision proxy capsule);
* an end-effector contact element (a finger, a mounted tool) with anything but what it is
  meant to touch: the scene's free objects, the tissue phantom, and the names in `allow`.
"""

from __future__ import annotations

import sys
from typing import TYPE_CHECKING, ClassVar

import numpy as np
from pydantic import Field

from .base import Envelope, Guard, GuardParams, Violation

if TYPE_CHECKING:
    from ..engine.context import Context
    from ..world.contacts import ContactSensor

__all__ = ["Collision"]


class CollisionParams(GuardParams):
    allow: list[str] = Field(
        default_factory=list,
        description="Scene bodies the end effector (fingers, a tool) may also touch "
        "(`table`, an obstacle, ...), besides free objects and the phantom.",
        json_schema_extra={"scene_ref": "body"},
    )


class Collision(Guard):
    """Fires on a contact between the robot and something it may not touch (see above)."""

    name: ClassVar[str] = "collision"
    Params: ClassVar[type[GuardParams]] = CollisionParams
    priority: ClassVar[int] = 4
    """Before `sensor_health`: a real impact can drive the wrist force out of the sensor's
    range, and it is then a collision, not a sensor fault."""
    ease_tolerance: ClassVar[float] = 0.001
    ease_unit: ClassVar[str] = "m"

    params: CollisionParams

    def bind(self, ctx: Context) -> None:
        sensors = ctx.world.contact_sensors
        w = ctx.world
        touchable = set(w.objects) | set(self.params.allow)
        if w.phantom is not None:
            touchable.add(w.phantom.name)
        self._sensors: tuple[ContactSensor, ...] = sensors
        if not sensors:
            self._block = self._forbidden = None
            return
        lo = min(s.adr for s in sensors)
        hi = max(s.adr for s in sensors) + 1
        mask = np.zeros(hi - lo)
        for s in sensors:
            if not (s.end_effector and s.partner in touchable):
                mask[s.adr - lo] = 1.0
        self._lo = lo
        self._mask = mask
        self._block = ctx.data.sensordata[lo:hi]  # a view: MjData never reallocates
        forbidden = np.flatnonzero(mask)
        # the world puts the forbidden sensors first: then one contiguous view says it all
        contiguous = len(forbidden) and forbidden[-1] - forbidden[0] + 1 == len(forbidden)
        self._forbidden = (
            ctx.data.sensordata[lo + forbidden[0] : lo + forbidden[-1] + 1] if contiguous else None
        )

    def check(self, ctx: Context) -> Violation | None:
        if self._forbidden is not None:
            if not any(self._forbidden.tolist()):
                return None
        elif self._block is None or not self._block.dot(self._mask):
            return None
        return self._violation(ctx)

    def _violation(self, ctx: Context) -> Violation:
        assert self._block is not None
        hits = [
            s
            for s in self._sensors
            if self._mask[s.adr - self._lo] and self._block[s.adr - self._lo]
        ]
        what = [f"{s.robot} ~ {s.partner or self._partner(ctx, s.robot)}" for s in hits]
        return Violation(
            self.name,
            "robot contact with " + ", ".join(what),
            what,
            "no contact",
        )

    @staticmethod
    def _partner(ctx: Context, robot_side: str) -> str:
        """Name what `robot_side` (a body or geom name) touches, from MuJoCo's contact list."""
        m, d = ctx.model, ctx.data
        names = []
        for i in range(d.ncon):
            g1, g2 = int(d.contact.geom[i][0]), int(d.contact.geom[i][1])
            for mine, other in ((g1, g2), (g2, g1)):
                body = m.body(int(m.geom_bodyid[mine])).name
                if robot_side in (body, m.geom(mine).name):
                    names.append(m.geom(other).name or m.body(int(m.geom_bodyid[other])).name)
        return "/".join(sorted(set(names))) or "?"

    def envelope(self, ctx: Context) -> Envelope:
        if self._forbidden is not None:  # no forbidden contact counted
            n = len(self._forbidden)
            return Envelope(bounds=((self._forbidden, [0.0] * n, [0.0] * n),))
        if self._block is None:  # no contact sensors: nothing can fire
            return Envelope()
        # the allowed sensors may count anything finite (an inf or a NaN: `check` decides)
        big = sys.float_info.max
        lo = [0.0 if m else -big for m in self._mask.tolist()]
        hi = [0.0 if m else big for m in self._mask.tolist()]
        return Envelope(bounds=((self._block, lo, hi),))

    def monitored(self, ctx: Context) -> tuple[float, float]:
        hits = 0.0 if self._block is None else float(self._block.dot(self._mask))
        return hits, 0.0

    def excess(self, ctx: Context) -> np.ndarray:
        """Per sensor of a forbidden contact: 0 while it counts none, else 1 + the deepest
        penetration of its contacts [m] (the 1 marks the contact itself: a contact that was
        not there is a new violation, a deeper one a growing one). Shape (forbidden sensors,).
        """
        if self._block is None:
            return np.zeros(0)
        forbidden = [s for s in self._sensors if self._mask[s.adr - self._lo]]
        depth = [0.0] * len(forbidden)
        m, d = ctx.model, ctx.data
        for i in range(d.ncon):
            g = (int(d.contact.geom[i][0]), int(d.contact.geom[i][1]))
            for mine, other in (g, g[::-1]):
                names = (m.geom(mine).name, m.body(int(m.geom_bodyid[mine])).name)
                partner = m.body(int(m.geom_bodyid[other])).name
                for k, s in enumerate(forbidden):
                    if s.robot in names and s.partner in (None, partner):
                        depth[k] = max(depth[k], -float(d.contact.dist[i]))
        return np.array(
            [
                1.0 + depth[k] if self._block[s.adr - self._lo] else 0.0
                for k, s in enumerate(forbidden)
            ]
        )
