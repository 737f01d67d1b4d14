"""`parcels_sorted`: every parcel went into the bin of its class or was rejected."""

from __future__ import annotations

from typing import TYPE_CHECKING, ClassVar

from .base import CheckParams, SuccessCheck, Verdict

if TYPE_CHECKING:
    from ..engine.context import Context

__all__ = ["ParcelsSorted"]


class ParcelsSortedParams(CheckParams):
    pass


class ParcelsSorted(SuccessCheck):
    """Every parcel of `scene.parcels` (or of a conveyor's shift) ended in the bin of its class
    or was rejected by the flow with a reason: the task log's verdicts, none missorted, dropped
    or left unsorted."""

    kind: ClassVar[str] = "parcels_sorted"
    Params: ClassVar[type[CheckParams]] = ParcelsSortedParams

    def evaluate(self, ctx: Context) -> Verdict:
        if not ctx.world.parcel_classes:
            return Verdict(False, "the scene has no parcels (scene.parcels)")
        entries = ctx.tasks.final or []
        belt = ctx.world.conveyor
        if belt is not None and belt.fed < belt.c.parcels:
            return Verdict(False, f"{belt.fed} of the shift's {belt.c.parcels} parcels were fed")
        bad = [e for e in entries if e.outcome not in ("sorted", "rejected")]
        counts = ", ".join(
            f"{n} {o}"
            for o in ("sorted", "rejected", "missorted", "dropped", "unsorted")
            if (n := sum(1 for e in entries if e.outcome == o))
        )
        if bad or not entries:
            worst = "; ".join(f"{e.id} ({e.true_class}) {e.outcome}" for e in bad[:5])
            return Verdict(False, f"{counts}: {worst}")
        return Verdict(True, counts)
