"""Success criteria, evaluated at the end of a run."""

from __future__ import annotations

import math

import mujoco
import numpy as np

from ..language.scenario import SuccessCheck
from .context import Context

__all__ = ["evaluate"]


def evaluate(ctx: Context, checks: dict[str, SuccessCheck]) -> dict[str, bool]:
    """Name -> passed, for every criterion of the scenario."""
    return {name: _check(ctx, c) for name, c in checks.items()}


def _check(ctx: Context, c: SuccessCheck) -> bool:
    if c.kind == "trace":
        return _traced(ctx.metrics, c)
    assert c.object is not None
    pose = ctx.object_pose(c.object)
    if c.kind == "object_at":
        assert c.target is not None
        target = ctx.world.markers[c.target]
        xy_err = float(np.linalg.norm(np.asarray(pose.pos[:2]) - target[:2]))
        w, x, y, z = pose.quat
        up = 1.0 - 2.0 * (x * x + y * y)
        upright = up >= math.cos(math.radians(c.upright_tol_deg))
        handle = ctx.world.objects[c.object]
        resting = pose.pos[2] < ctx.world.table_height + handle.half_size[2] + 0.01
        return bool(xy_err <= c.xy_tol_m and upright and resting)
    # gripper_clear: opened wider than the object, and no finger within min_distance of it
    handle = ctx.world.objects[c.object]
    open_enough = ctx.gripper_width >= 2.0 * float(max(handle.half_size)) + 2.0 * c.min_distance_m
    fromto = np.zeros(6)
    for g in ctx.world.finger_geoms:
        dist = mujoco.mj_geomDistance(
            ctx.model, ctx.data, g, handle.geom_id, c.min_distance_m + 0.05, fromto
        )
        if dist < c.min_distance_m:
            return False
    return bool(open_enough)


def _traced(m: dict, c: SuccessCheck) -> bool:
    """A trace ran and its ground-truth figures (engine/trace_truth.py) are within bounds."""
    if "true_cross_track_max_mm" not in m:
        return False
    return bool(
        m["true_cross_track_max_mm"] <= c.cross_track_max_mm
        and m["trace_end_gap_mm"] <= c.end_tol_mm
        and m["true_force_rms_error_n"] <= c.force_rms_max_n
        and m["true_peak_force_n"] <= c.force_peak_max_n
    )
