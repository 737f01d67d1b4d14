"""Success criteria, evaluated at the end of a run, each with what it measured."""

from __future__ import annotations

import math

import mujoco
import numpy as np

from ..exceptions import OrchestratorError
from ..language.scenario import SuccessCheck
from ..skills.gripper import grasped_height
from ..skills.targets import resolve_target
from ..world.randomization import object_poses
from .context import Context

__all__ = ["errors", "evaluate"]


def evaluate(ctx: Context, checks: dict[str, SuccessCheck]) -> dict[str, tuple[bool, str]]:
    """Name -> (passed, what was measured against what limit), for every criterion."""
    return {name: _check(ctx, c) for name, c in checks.items()}


def errors(ctx: Context, checks: dict[str, SuccessCheck]) -> dict[str, float]:
    """The measured error of every `object_at` criterion, as a metric: `<name>_xy_error_mm`,
    the distance in the table plane from the object's centre to its target [mm]."""
    out = {}
    for name, c in checks.items():
        if c.kind == "object_at" and c.target is not None and c.object is not None:
            pos = ctx.object_pose(c.object).pos
            try:
                goal = resolve_target(ctx, ctx.blackboard.resolve(c.target))
            except OrchestratorError:
                continue  # `evaluate` reports why the target cannot be found
            err = float(np.linalg.norm(np.asarray(pos[:2]) - np.asarray(goal.pos[:2])))
            out[f"{name}_xy_error_mm"] = round(err * 1000.0, 3)
    return out


def _check(ctx: Context, c: SuccessCheck) -> tuple[bool, str]:
    if c.kind == "trace":
        return _traced(ctx.metrics, c)
    if c.kind == "parcels_sorted":
        return _sorted(ctx)
    assert c.object is not None
    pose = ctx.object_pose(c.object)
    handle = ctx.world.objects[c.object]
    if c.kind == "object_at":
        assert c.target is not None
        try:
            # a `$key` target follows the blackboard: where the flow was told to place
            goal = resolve_target(ctx, ctx.blackboard.resolve(c.target))
        except OrchestratorError as exc:
            return False, f"target {c.target!r}: {exc}"
        xy_err = float(np.linalg.norm(np.asarray(pose.pos[:2]) - np.asarray(goal.pos[:2])))
        w, x, y, z = pose.quat
        tilt = math.degrees(math.acos(max(-1.0, min(1.0, 1.0 - 2.0 * (x * x + y * y)))))
        height = pose.pos[2] - ctx.world.table_height - handle.half_size[2]
        where = np.round(np.asarray(goal.pos[:2]), 3).tolist()
        problems = []
        if xy_err > c.xy_tol_m:
            problems.append(
                f"{c.object} is {xy_err * 1000:.1f} mm from {where} (xy_tol_m "
                f"{c.xy_tol_m * 1000:g} mm)"
            )
        if tilt > c.upright_tol_deg:
            problems.append(f"tilted {tilt:.1f} deg (upright_tol_deg {c.upright_tol_deg:g})")
        if height >= 0.01:
            problems.append(f"not resting on the table ({height * 1000:.0f} mm above it)")
        if problems:
            return False, "; ".join(problems)
        return True, f"{c.object} {xy_err * 1000:.1f} mm from {where}, tilted {tilt:.1f} deg"
    if c.kind == "held":
        return _held(ctx, c, pose.pos)
    # gripper_clear: opened wider than the object, and no finger within min_distance of it
    need = 2.0 * float(max(handle.half_size)) + 2.0 * c.min_distance_m
    fromto = np.zeros(6)
    nearest = math.inf
    for g in ctx.world.finger_geoms:
        dist = mujoco.mj_geomDistance(
            ctx.model, ctx.data, g, handle.geom_id, c.min_distance_m + 0.05, fromto
        )
        nearest = min(nearest, float(dist))
    gap = f"fingers {nearest * 1000:.1f} mm from {c.object} (min_distance_m {c.min_distance_m:g})"
    if nearest < c.min_distance_m:
        return False, gap
    if ctx.gripper_width < need:
        return False, f"gripper open {ctx.gripper_width * 1000:.1f} mm < {need * 1000:.1f} mm"
    return True, gap


def _held(ctx: Context, c: SuccessCheck, pos) -> tuple[bool, str]:
    """Both fingers touch the object, lifted `min_lift_m` above where it lay when the fingers
    last closed on it (its seeded start if they never did)."""
    assert c.object is not None
    grasped = grasped_height(ctx, c.object)
    start = (
        grasped
        if grasped is not None
        else next(p for n, p, _ in object_poses(ctx.scenario, ctx.world.seed) if n == c.object)[2]
    )
    lift = float(pos[2] - start)
    geom = ctx.world.objects[c.object].geom_id
    d, m = ctx.data, ctx.model
    touching = set()
    for i in range(d.ncon):
        g1, g2 = int(d.contact[i].geom1), int(d.contact[i].geom2)
        if geom in (g1, g2):
            other = g2 if g1 == geom else g1
            if other in ctx.world.finger_geoms:
                touching.add(int(m.geom_bodyid[other]))
    since = "where it was grasped" if grasped is not None else "its start"
    what = f"{c.object} {lift * 1000:.0f} mm above {since}, {len(touching)} finger(s) on it"
    if len(touching) < 2 or lift < c.min_lift_m:
        return False, f"{what} (need 2 and min_lift_m {c.min_lift_m * 1000:g} mm)"
    return True, what


def _traced(m: dict, c: SuccessCheck) -> tuple[bool, str]:
    """A trace ran and its ground-truth figures (engine/trace_truth.py) are within bounds."""
    if "true_cross_track_max_mm" not in m:
        return False, "no trace ran (no ground-truth trace figures)"
    figures = (
        ("true_cross_track_max_mm", c.cross_track_max_mm, "cross_track_max_mm"),
        ("trace_end_gap_mm", c.end_tol_mm, "end_tol_mm"),
        ("true_force_rms_error_n", c.force_rms_max_n, "force_rms_max_n"),
        ("true_peak_force_n", c.force_peak_max_n, "force_peak_max_n"),
    )
    over = [
        f"{key} {m[key]:g} > {name} {limit:g}" for key, limit, name in figures if m[key] > limit
    ]
    if over:
        return False, "; ".join(over)
    return True, ", ".join(f"{key} {m[key]:g}" for key, _, _ in figures)


def _sorted(ctx: Context) -> tuple[bool, str]:
    """Every parcel sorted or rejected with a reason (the task log's verdicts)."""
    if not ctx.world.parcel_classes:
        return False, "the scene has no parcels (scene.parcels)"
    entries = ctx.tasks.final or []
    belt = ctx.world.conveyor
    if belt is not None and belt.fed < belt.c.parcels:
        return False, f"{belt.fed} of the shift's {belt.c.parcels} parcels were fed"
    bad = [e for e in entries if e.outcome not in ("sorted", "rejected")]
    counts = ", ".join(
        f"{n} {o}"
        for o in ("sorted", "rejected", "missorted", "dropped", "unsorted")
        if (n := sum(1 for e in entries if e.outcome == o))
    )
    if bad or not entries:
        worst = "; ".join(f"{e.id} ({e.true_class}) {e.outcome}" for e in bad[:5])
        return False, f"{counts}: {worst}"
    return True, counts
