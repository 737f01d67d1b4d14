"""Ground truth of a contact trace, measured every physics step against the real path.

A contact skill traces a path given in a frame it was handed — a registered pose, an
estimate with its registration error. What a surgeon cares about is where the tip went on the
real tissue: this probe maps the same waypoints through the true pose of the phantom (the
world, for a path given in the world) and, at every physics step the tip is in the tissue (from
the moment the force reached its target at the path's start, the dwell there included, to the
end of the lateral motion: `true_contact_s` long), measures

* cross-track error: the tip's lateral distance from the true path [mm];
* along-track error: how far the tip is behind (+) or ahead of (-) the skill's setpoint,
  both projected on the true path [mm];
* the true normal force against the force the skill holds [N].

The skill's own `path_deviation_*` figures are per control tick, cross-track only and
against the registered path: they stay, for comparison; these are the honest ones.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np

from ..world.path import PlannedPath, TraceSpec

if TYPE_CHECKING:
    from .context import Context

__all__ = ["TraceTruth"]


class TraceTruth:
    """Per-step ground truth of every trace of an episode (an `on_step` observer)."""

    def __init__(self, ctx: Context) -> None:
        self.ctx = ctx
        self._spec: TraceSpec | None = None
        self._true: PlannedPath | None = None
        self.steps = 0
        self._cross_sq = 0.0
        self._cross_max = 0.0
        self._along_sum = 0.0
        self._along_max = 0.0
        self._force_err_sq = 0.0
        self._force_peak = 0.0
        self._end_gap = math.inf
        self._tip = ctx.data.site_xpos[ctx.world.tcp_site]

    def on_step(self, ctx: Context) -> None:
        spec = ctx.trace
        if spec is None:
            return
        if spec is not self._spec:
            self._spec, self._true = spec, PlannedPath(*self._true_path(spec))
        true = self._true
        assert true is not None
        tip = self._tip
        cross = true.deviation(tip)
        along = true.progress(spec.reference) - true.progress(tip)
        fx, fy, fz = ctx.cell.wrist.true_force()
        n = spec.normal
        f_n = -(fx * n[0] + fy * n[1] + fz * n[2])
        self.steps += 1
        self._cross_sq += cross * cross
        self._cross_max = max(self._cross_max, cross)
        self._along_sum += along
        self._along_max = max(self._along_max, abs(along))
        err = spec.target_force_n - f_n
        self._force_err_sq += err * err
        self._force_peak = max(self._force_peak, math.sqrt(fx * fx + fy * fy + fz * fz))
        self._end_gap = true.length - true.progress(tip)

    def _true_path(self, spec: TraceSpec) -> tuple[np.ndarray, np.ndarray]:
        """The waypoints in the world through the true pose (shape (k, 3)) and the true
        normal along which distance does not count (shape (3,)): the phantom's surface
        normal for a path given in a frame on a phantom, else the skill's own axis."""
        local = spec.local_points
        if spec.frame is None:
            return local.copy(), spec.normal
        phantom = self.ctx.world.phantom
        if phantom is None:  # no truth known beyond the frame given: the frame is the truth
            pos, rot = spec.frame
            return local @ rot.T + pos, spec.normal
        rot = phantom.rotation
        return local @ rot.T + phantom.surface_pos, rot[:, 2]

    def figures(self) -> dict[str, Any]:
        """The run's ground-truth trace metrics (empty when nothing was traced)."""
        if not self.steps:
            return {}
        k = self.steps
        return {
            "true_cross_track_rms_mm": round(math.sqrt(self._cross_sq / k) * 1000, 4),
            "true_cross_track_max_mm": round(self._cross_max * 1000, 4),
            "along_track_lag_mean_mm": round(float(self._along_sum) / k * 1000, 4),
            "along_track_max_mm": round(float(self._along_max) * 1000, 4),
            "true_force_rms_error_n": round(math.sqrt(self._force_err_sq / k), 4),
            "true_peak_force_n": round(self._force_peak, 4),
            "trace_end_gap_mm": round(float(self._end_gap) * 1000, 4),
            "true_contact_s": round(k * self.ctx.dt_physics, 4),
        }
