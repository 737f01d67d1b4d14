"""`contact_force`: the external force at the wrist stays below a limit."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, ClassVar

from pydantic import Field, PositiveFloat

from ..guard import Guard, GuardParams, Violation

if TYPE_CHECKING:
    from ..context import Context

__all__ = ["ContactForce"]


class ContactForceParams(GuardParams):
    max_n: PositiveFloat = Field(default=40.0, description="Largest allowed force norm [N].")


class ContactForce(Guard):
    """Fires when the norm of the wrist force (hand weight removed) exceeds `max_n`."""

    name: ClassVar[str] = "contact_force"
    Params: ClassVar[type[GuardParams]] = ContactForceParams

    params: ContactForceParams

    def bind(self, ctx: Context) -> None:
        w = ctx.world
        # check() runs every physics step: it computes `ctx.wrist_force()` inline, with plain
        # floats on views bound once (MjData never reallocates).
        self._f_site = ctx.data.sensordata[w.force_adr : w.force_adr + 3]
        self._rot = ctx.data.site_xmat[w.wrist_site]
        self._bias = w.wrist_bias_world  # a view: zeroing the sensor updates it in place
        self._max_sq = self.params.max_n * self.params.max_n

    def check(self, ctx: Context) -> Violation | None:
        f0, f1, f2 = self._f_site.tolist()
        r = self._rot.tolist()
        bx, by, bz = self._bias.tolist()
        fx = bx - (r[0] * f0 + r[1] * f1 + r[2] * f2)
        fy = by - (r[3] * f0 + r[4] * f1 + r[5] * f2)
        fz = bz - (r[6] * f0 + r[7] * f1 + r[8] * f2)
        if fx * fx + fy * fy + fz * fz <= self._max_sq:
            return None
        f = ctx.wrist_force()
        norm = math.sqrt(float(f @ f))
        return Violation(
            self.name,
            f"wrist force {norm:.2f} N exceeds {self.params.max_n} N",
            round(norm, 4),
            self.params.max_n,
        )

    def monitored(self, ctx: Context) -> tuple[float, float]:
        f = ctx.wrist_force()
        return math.sqrt(float(f @ f)), self.params.max_n
