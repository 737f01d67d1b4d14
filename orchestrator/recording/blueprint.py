"""The default viewer layout: one screen that tells the story of a run."""

from __future__ import annotations

from collections.abc import Sequence

import mujoco
import numpy as np
import rerun.blueprint as rrb

from .paths import ACTIVE_STATE, CAMERAS, EVENTS, GRAPH, GUARDS, LEVELS, SIM_TIME, WORLD
from .signals import GRIPPER_WIDTH, JOINT_TORQUE, TCP_ERROR, WRIST_FORCE

__all__ = ["default_blueprint", "graph_view_bounds", "machine_share"]

_PLOTS_SHARE = 0.24
"""Width of the plots-and-events column, as a share of the window."""
_MACHINE_SHARE = (0.28, 0.5)
"""Least and most width of the machine graph's column, as a share of the window."""
_PANEL_H_PX, _WINDOW_W_PX = 800.0, 1600.0
"""The graph panel's height in a 1600x900 window, and that window's width [px]."""
_MARGIN_PX = (16.0, 30.0)
"""Room kept around the graph: sides and bottom, top [px]. Rerun outlines the graph 10 px
outside its nodes and writes the entity path above the outline; its own fit leaves that out."""


def graph_view_bounds(bounds: tuple[float, float, float, float]) -> rrb.VisualBounds2D:
    """What the machine graph's view shows: the layout's `bounds` (x0, y0, x1, y1) [px] and
    the room Rerun draws around it."""
    x0, y0, x1, y1 = bounds
    side, top = _MARGIN_PX
    return rrb.VisualBounds2D(x_range=[x0 - side, x1 + side], y_range=[y0 - top, y1 + side])


def machine_share(bounds: tuple[float, float, float, float] | None) -> float:
    """The share of the window's width that shows a graph laid out within `bounds` (x0, y0,
    x1, y1) [px] at zoom 1 in a 1600x900 window (the panel is ~800 px high), within
    `_MACHINE_SHARE`."""
    lo, hi = _MACHINE_SHARE
    if bounds is None:
        return lo
    side, top = _MARGIN_PX
    w = bounds[2] - bounds[0] + 2 * side
    h = bounds[3] - bounds[1] + side + top
    zoom = min(1.0, _PANEL_H_PX / h)
    return float(np.clip(w * zoom / _WINDOW_W_PX, lo, hi))


def default_blueprint(
    model: mujoco.MjModel | None = None,
    graph_bounds: tuple[float, float, float, float] | None = None,
    cameras: Sequence[str] = (),
) -> rrb.Blueprint:
    """The layout a saved or live recording opens with.

    Left: the 3D scene above the state lanes (what the robot did, and in which state).
    Middle: the machine graph, full height, its active states lit. Right: guard margins
    against their limits, force, tracking error and torques, and the event log (errors in
    red). The time panel is a single row following `sim_time`.

    Args:
        model: If given, the 3D camera frames the model (its `stat.center` and `stat.extent`).
        graph_bounds: Where the machine graph's layout lies (x0, y0, x1, y1) [px]: the view
            shows exactly that, and its column is made wide enough to show it at zoom 1 in a
            1600x900 window (within 28-50% of the width).
        cameras: Scenario cameras: each gets a 2D view (its image, depth, segmentation and
            detections) under the 3D scene.
    """
    eye = None
    if model is not None:
        center = np.asarray(model.stat.center, dtype=np.float64)
        extent = max(float(model.stat.extent), 0.5)
        eye = rrb.EyeControls3D(
            position=(center + extent * np.array([1.1, -1.3, 0.9])).tolist(),
            look_target=center.tolist(),
            eye_up=[0.0, 0.0, 1.0],
        )
    scene = rrb.Spatial3DView(name="Scene", origin=WORLD, eye_controls=eye)
    states = rrb.StateTimelineView(
        name="States", origin="/", contents=[ACTIVE_STATE, f"{LEVELS}/**"]
    )
    right = rrb.Vertical(
        rrb.TimeSeriesView(name="Guards: value vs limit", origin=GUARDS),
        rrb.TimeSeriesView(name="Wrist force [N]", origin=WRIST_FORCE),
        rrb.TimeSeriesView(name="TCP error, gripper [m]", contents=[TCP_ERROR, GRIPPER_WIDTH]),
        rrb.TimeSeriesView(name="Joint torques [N m]", origin=JOINT_TORQUE),
        rrb.TextLogView(name="Events", origin=EVENTS),
    )
    machine = machine_share(graph_bounds)
    graph = rrb.GraphView(
        name="Machine",
        origin=GRAPH,
        visual_bounds=graph_view_bounds(graph_bounds) if graph_bounds is not None else None,
    )
    left = rrb.Vertical(scene, states, row_shares=[3, 1])
    if cameras:
        views = [rrb.Spatial2DView(name=f"Camera {c}", origin=f"{CAMERAS}/{c}") for c in cameras]
        left = rrb.Vertical(scene, rrb.Horizontal(*views), states, row_shares=[3, 2, 1])
    return rrb.Blueprint(
        rrb.Horizontal(
            left,
            graph,
            right,
            column_shares=[1.0 - machine - _PLOTS_SHARE, machine, _PLOTS_SHARE],
        ),
        rrb.TimePanel(timeline=SIM_TIME, state="collapsed"),
        rrb.BlueprintPanel(state="collapsed"),
        rrb.SelectionPanel(state="collapsed"),
    )
