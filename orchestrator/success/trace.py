"""`trace`: a contact trace ran to the end of its path on the real surface, within bounds."""

from __future__ import annotations

from typing import TYPE_CHECKING, ClassVar

from pydantic import Field, PositiveFloat

from .base import CheckParams, SuccessCheck, Verdict

if TYPE_CHECKING:
    from ..engine.context import Context

__all__ = ["Trace"]


class TraceParams(CheckParams):
    cross_track_max_mm: PositiveFloat = Field(
        default=0.1,
        le=1000.0,
        description="Largest lateral error from the true path [mm] (a surgical bar: a deviation "
        "of 0.1 mm already matters).",
    )
    end_tol_mm: PositiveFloat = Field(
        default=2.0, le=1000.0, description="Tip within this of the true path's end [mm]."
    )
    force_rms_max_n: PositiveFloat = Field(
        default=0.5, le=1000.0, description="RMS error of the true normal force [N]."
    )
    force_peak_max_n: PositiveFloat = Field(
        default=5.0, le=1000.0, description="Largest true wrist force while tracing [N]."
    )


class Trace(SuccessCheck):
    """A contact trace ran to the end of its path on the real surface — measured every physics
    step against the true path (not the registered one, engine/trace_truth.py): cross-track
    error within `cross_track_max_mm` at every step, the tip within `end_tol_mm` of the true
    path's end along it, the true normal force within `force_rms_max_n` RMS of the target and
    never above `force_peak_max_n`."""

    kind: ClassVar[str] = "trace"
    Params: ClassVar[type[CheckParams]] = TraceParams
    params: TraceParams

    def evaluate(self, ctx: Context) -> Verdict:
        m, p = ctx.metrics, self.params
        if "true_cross_track_max_mm" not in m:
            return Verdict(False, "no trace ran (no ground-truth trace figures)")
        figures = (
            ("true_cross_track_max_mm", p.cross_track_max_mm, "cross_track_max_mm"),
            ("trace_end_gap_mm", p.end_tol_mm, "end_tol_mm"),
            ("true_force_rms_error_n", p.force_rms_max_n, "force_rms_max_n"),
            ("true_peak_force_n", p.force_peak_max_n, "force_peak_max_n"),
        )
        over = [
            f"{key} {m[key]:g} > {name} {limit:g}" for key, limit, name in figures if m[key] > limit
        ]
        if over:
            return Verdict(False, "; ".join(over))
        return Verdict(True, ", ".join(f"{key} {m[key]:g}" for key, _, _ in figures))
