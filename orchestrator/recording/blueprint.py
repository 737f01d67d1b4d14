"""The default viewer layout: one screen that tells the story of a run."""

from __future__ import annotations

import mujoco
import numpy as np
import rerun.blueprint as rrb

from .paths import ACTIVE_STATE, EVENTS, GRAPH, GUARDS, LEVELS, SIM_TIME, WORLD
from .signals import GRIPPER_WIDTH, JOINT_TORQUE, TCP_ERROR, WRIST_FORCE

__all__ = ["default_blueprint"]


def default_blueprint(model: mujoco.MjModel | None = None) -> rrb.Blueprint:
    """The layout a saved or live recording opens with.

    Left: the 3D scene above the state lanes (what the robot did, and in which state).
    Right: the machine graph with the active state lit, guard margins against their limits,
    force, tracking error and torques, and the event log (errors in red). The time panel
    follows `sim_time`.

    Args:
        model: If given, the 3D camera frames the model (its `stat.center` and `stat.extent`).
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
    plots = rrb.Grid(
        rrb.TimeSeriesView(name="Guards: value vs limit", origin=GUARDS),
        rrb.TimeSeriesView(name="Wrist force [N]", origin=WRIST_FORCE),
        rrb.TimeSeriesView(name="TCP error, gripper [m]", contents=[TCP_ERROR, GRIPPER_WIDTH]),
        rrb.TimeSeriesView(name="Joint torques [N m]", origin=JOINT_TORQUE),
        grid_columns=2,
    )
    return rrb.Blueprint(
        rrb.Horizontal(
            rrb.Vertical(scene, states, row_shares=[3, 1]),
            rrb.Vertical(
                rrb.GraphView(name="Machine", origin=GRAPH),
                plots,
                rrb.TextLogView(name="Events", origin=EVENTS),
                row_shares=[2, 3, 2],
            ),
            column_shares=[3, 2],
        ),
        rrb.TimePanel(timeline=SIM_TIME),
        rrb.BlueprintPanel(state="collapsed"),
        rrb.SelectionPanel(state="collapsed"),
    )
