"""`contact_force`: the external force at the wrist stays below a limit."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, ClassVar

import numpy as np
from pydantic import Field, PositiveFloat

from .base import Envelope, Guard, GuardParams, Violation

if TYPE_CHECKING:
    from ..engine.context import Context

__all__ = ["ContactForce"]


class ContactForceParams(GuardParams):
    max_n: PositiveFloat = Field(
        default=40.0,
        le=10_000.0,
        description="Largest allowed force norm [N] (at most 10 kN: a larger limit never fires).",
    )


class ContactForce(Guard):
    """Fires when the norm of the wrist force (hand weight removed) exceeds `max_n`."""

    name: ClassVar[str] = "contact_force"
    Params: ClassVar[type[GuardParams]] = ContactForceParams
    ease_tolerance: ClassVar[float] = 2.0
    ease_unit: ClassVar[str] = "N"

    params: ContactForceParams

    def bind(self, ctx: Context) -> None:
        self._max_sq = self.params.max_n * self.params.max_n

    def check(self, ctx: Context) -> Violation | None:
        norm_sq = ctx.wrist_force_norm_sq()
        if norm_sq <= self._max_sq:
            return None
        norm = math.sqrt(norm_sq)
        return Violation(
            self.name,
            f"wrist force {norm:.2f} N exceeds {self.params.max_n} N",
            round(norm, 4),
            self.params.max_n,
        )

    def envelope(self, ctx: Context) -> Envelope:
        return Envelope(scalars=((ctx.wrist_force_norm_sq, self._max_sq),))

    def monitored(self, ctx: Context) -> tuple[float, float]:
        return math.sqrt(ctx.wrist_force_norm_sq()), self.params.max_n

    def excess(self, ctx: Context) -> np.ndarray:
        """The wrist force norm above `max_n` [N]. Shape (1,)."""
        return np.array([math.sqrt(ctx.wrist_force_norm_sq()) - self.params.max_n])
