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

    def check(self, ctx: Context) -> Violation | None:
        f = ctx.wrist_force()
        norm = math.sqrt(float(f @ f))
        if norm <= self.params.max_n:
            return None
        return Violation(
            self.name,
            f"wrist force {norm:.2f} N exceeds {self.params.max_n} N",
            round(norm, 4),
            self.params.max_n,
        )

    def monitored(self, ctx: Context) -> tuple[float, float]:
        f = ctx.wrist_force()
        return math.sqrt(float(f @ f)), self.params.max_n
