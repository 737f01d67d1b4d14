"""The default viewer layout: one screen that tells the story of a run."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import rerun.blueprint as rrb
from rerun.blueprint.encodings import TextLogColumn, TimelineColumn

from .framing import WorkFrame
from .guard_margins import UNITS, unit_of
from .paths import (
    ACTIVE_STATE,
    CAMERAS,
    EVENTS,
    GRAPH,
    GUARD_VALUES,
    GUARDS,
    LEVELS,
    RESULT,
    SIM_TIME,
    WORLD,
    part,
)
from .signals import GRIPPER_WIDTH, JOINT_TORQUE, TCP_ERROR, WRIST_FORCE, WRIST_FORCE_XYZ

__all__ = [
    "LEGIBLE_ZOOM",
    "WINDOWS",
    "default_blueprint",
    "graph_panel_px",
    "graph_view_bounds",
    "graph_zoom",
    "margins_legend_rows",
    "margins_range",
    "panel_zoom",
    "scene_aspect",
    "machine_share",
]

_PLOTS_SHARE = 0.27
"""Width of the plots-and-events column, as a share of the window."""
_MACHINE_SHARE = (0.24, 0.52)
"""Least and most width of the machine graph's column, as a share of the window."""
WINDOWS = ((1600, 900), (1280, 720))
"""The browser windows the layout is made for [px]: a laptop's and a small one."""
_CHROME_PX = 100.0
"""Window height the graph panel does not get: the viewer's top bar, the collapsed time
panel and the view's title bar [px] (measured in Rerun 0.41's web viewer: an 800 px panel in
a 900 px window)."""
LEGIBLE_ZOOM = 0.75
"""The least zoom at which the graph's 12 px labels are legible (9 px text): every bundled
machine's graph is shown at it or more in both `WINDOWS`, laid out by `dot` or without it."""
_MARGIN_PX = (16.0, 30.0)
"""Room kept around the graph: sides and bottom, top [px]. Rerun outlines the graph 10 px
outside its nodes and writes the entity path above the outline; its own fit leaves that out."""
_LANES_WINDOW_S = (6.0, 2.0)
"""The state lanes show this much simulated time before and after the cursor [s]: 8 s across
the lanes, so a state of half a second is wide enough for its name in a long run."""
_LEGEND_ROW_PX, _LEGEND_PAD_PX = 18.0, 14.0
"""Height of a plot legend's row, and its frame's padding and margin [px] (Rerun 0.41)."""
_MARGINS_PLOT_PX = 190.0
"""Height of the guard margins' plot area in the smaller window [px]: its panel's share of the
right column, less the tab bar and the time axis."""
_MARGINS_TOP = 1.15
"""The guard margins' y axis shows at least up to here: the trip line (1.0) and a bit above."""


_LEGEND_MOST_SHARE = 0.5
"""The most of the margins' plot height its legend may take; with more guards than fit,
the legend is hidden (a line's name shows on hover; the raw-value tabs name them)."""


def margins_legend_rows(n_guards: int) -> int:
    """The rows of the margins' legend: the trip line's and one per guard; 0 if it does not
    fit in `_LEGEND_MOST_SHARE` of the plot in the smaller window (then it is hidden)."""
    rows = n_guards + 1
    fits = rows * _LEGEND_ROW_PX + _LEGEND_PAD_PX <= _LEGEND_MOST_SHARE * _MARGINS_PLOT_PX
    return rows if fits else 0


def margins_range(n_guards: int) -> tuple[float, float]:
    """The guard margins' y axis: 0 to just above the trip line (1.0) and, above that, the
    room the legend (top left) takes in the smaller window: the legend lies above the data,
    never on the trip line."""
    rows = margins_legend_rows(n_guards)
    share = (rows * _LEGEND_ROW_PX + _LEGEND_PAD_PX) / _MARGINS_PLOT_PX if rows else 0.0
    return 0.0, _MARGINS_TOP / (1.0 - share)


def graph_view_bounds(bounds: tuple[float, float, float, float]) -> rrb.VisualBounds2D:
    """What the machine graph's view shows: the layout's `bounds` (x0, y0, x1, y1) [px] and
    the room Rerun draws around it."""
    x0, y0, x1, y1 = bounds
    side, top = _MARGIN_PX
    return rrb.VisualBounds2D(x_range=[x0 - side, x1 + side], y_range=[y0 - top, y1 + side])


def _shown_size(bounds: tuple[float, float, float, float]) -> tuple[float, float]:
    side, top = _MARGIN_PX
    return bounds[2] - bounds[0] + 2 * side, bounds[3] - bounds[1] + side + top


def graph_panel_px(share: float, window: tuple[int, int]) -> tuple[float, float]:
    """The size of the graph panel [px] in a browser window `window` (w, h) [px] when its
    column is `share` of the width."""
    return share * window[0], window[1] - _CHROME_PX


def graph_zoom(bounds: tuple[float, float, float, float], share: float, window: tuple[int, int]):
    """The zoom Rerun shows a graph within `bounds` at, in a column of `share` of `window`:
    the view fits its visual bounds in the panel, and never zooms in past 1."""
    w, h = _shown_size(bounds)
    pw, ph = graph_panel_px(share, window)
    return min(1.0, pw / w, ph / h)


def panel_zoom(bounds: tuple[float, float, float, float]) -> float:
    """The zoom a graph within `bounds` [px] is shown at in the smallest of `WINDOWS` with the
    machine graph's column at its widest: what a layout is chosen by (graph_dot.py)."""
    return graph_zoom(bounds, _MACHINE_SHARE[1], min(WINDOWS))


def machine_share(bounds: tuple[float, float, float, float] | None) -> float:
    """The share of the window's width the machine graph gets: enough to show a graph within
    `bounds` (x0, y0, x1, y1) [px] at the zoom its panel's height allows (at most 1) in the
    smallest of `WINDOWS`, within `_MACHINE_SHARE`."""
    lo, hi = _MACHINE_SHARE
    if bounds is None:
        return lo
    w, h = _shown_size(bounds)
    window = min(WINDOWS)
    zoom = min(1.0, graph_panel_px(1.0, window)[1] / h)
    return float(np.clip(w * zoom / window[0], lo, hi))


def default_blueprint(
    frame: WorkFrame | None = None,
    graph_bounds: tuple[float, float, float, float] | None = None,
    cameras: Sequence[str] = (),
    guards: Sequence[str] = (),
) -> rrb.Blueprint:
    """The layout a saved or live recording opens with.

    Left: the 3D scene framed on the work, the cameras (each its RGB image with the
    detections over it; depth and segmentation are layers to turn on), the state lanes.
    Middle: the machine graph, full height, its active states lit. Right: how the run ended
    (while it runs: that it runs), the guards' margins (raw values behind, one tab per unit),
    the wrist force (TCP error, gripper and torques in tabs behind) and the event log. The
    time panel is a single row following `sim_time`. No legend lies on data: the margins'
    axis leaves room above the trip line for theirs (hidden when too many guards for the
    room), the other plots name their lines in their titles.

    Args:
        frame: If given, the 3D view's eye frames this work (framing.py); the user zooms out
            with the mouse wheel.
        graph_bounds: A box holding every expansion of the machine graph (x0, y0, x1, y1)
            [px]: the view shows exactly that, its column wide enough to show it at the zoom
            its height allows.
        cameras: Scenario cameras: each gets a 2D view under the 3D scene.
        guards: The names of the guards the run can activate (guard_margins.declared_guards):
            a raw-values tab per unit among them.
    """
    machine = machine_share(graph_bounds)
    scene_rows = _SCENE_ROWS_CAMERAS if cameras else _SCENE_ROWS
    eye = None
    if frame is not None:
        aspect = scene_aspect(1.0 - machine - _PLOTS_SHARE, scene_rows[0] / sum(scene_rows))
        position, target = frame.eye_for(aspect)
        eye = rrb.EyeControls3D(
            position=position.tolist(), look_target=target.tolist(), eye_up=[0, 0, 1]
        )
    hidden = rrb.EntityBehavior(visible=False)
    layers = {
        f"{CAMERAS}/{c}/{layer}": hidden for c in cameras for layer in ("depth", "segmentation")
    }
    scene = rrb.Spatial3DView(
        name="Scene",
        origin=WORLD,
        contents=["$origin/**", *(f"- {path}" for path in layers)],
        eye_controls=eye,
    )
    states = rrb.StateTimelineView(
        name="States",
        origin="/",
        contents=[ACTIVE_STATE, f"{LEVELS}/**"],
        time_view=rrb.TimeAxis(
            view_range=rrb.TimeRange(
                start=rrb.TimeRangeBoundary.cursor_relative(seconds=-_LANES_WINDOW_S[0]),
                end=rrb.TimeRangeBoundary.cursor_relative(seconds=_LANES_WINDOW_S[1]),
            )
        ),
    )
    no_legend = rrb.PlotLegend(visible=False)
    guards_tabs = rrb.Tabs(
        rrb.TimeSeriesView(
            name="Guards: margin (1.0 = fires)",
            origin=GUARDS,
            axis_y=rrb.ScalarAxis(range=margins_range(len(guards)), zoom_lock=False),
            plot_legend=rrb.PlotLegend(
                corner="LeftTop", visible=margins_legend_rows(len(guards)) > 0
            ),
        ),
        *_raw_value_views(guards),
        active_tab=0,
    )
    signals = rrb.Tabs(
        rrb.TimeSeriesView(
            name="Wrist |F| [N] (orange: peak per tick)",
            origin=WRIST_FORCE,
            plot_legend=no_legend,
        ),
        rrb.TimeSeriesView(
            name="Force [N]: x red, y green, z blue",
            origin=WRIST_FORCE_XYZ,
            plot_legend=no_legend,
        ),
        rrb.TimeSeriesView(name="TCP error, gripper [m]", contents=[TCP_ERROR, GRIPPER_WIDTH]),
        rrb.TimeSeriesView(name="Joint torques [N m]", origin=JOINT_TORQUE),
        active_tab=0,
    )
    events = rrb.TextLogView(
        name="Events",
        origin=EVENTS,
        columns=rrb.TextLogColumns(
            timeline_columns=[TimelineColumn(SIM_TIME, visible=True)],
            text_log_columns=[
                TextLogColumn("EntityPath", visible=False),
                TextLogColumn("LogLevel"),
                TextLogColumn("Body"),
            ],
        ),
    )
    result = rrb.TextDocumentView(name="Result", origin=RESULT)
    right = rrb.Vertical(result, guards_tabs, signals, events, row_shares=_RIGHT_ROWS)
    graph = rrb.GraphView(
        name="Machine",
        origin=GRAPH,
        visual_bounds=graph_view_bounds(graph_bounds) if graph_bounds is not None else None,
    )
    left = rrb.Vertical(scene, states, row_shares=list(scene_rows))
    if cameras:
        views = [
            rrb.Spatial2DView(
                name=f"Camera {c} (depth, segmentation: eye icons)",
                origin=f"{CAMERAS}/{c}",
                overrides={p: v for p, v in layers.items() if p.startswith(f"{CAMERAS}/{c}/")},
            )
            for c in cameras
        ]
        left = rrb.Vertical(scene, rrb.Horizontal(*views), states, row_shares=list(scene_rows))
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


_SCENE_ROWS = (3.0, 2.0)
"""Row shares of the left column: the 3D scene, the state lanes."""
_SCENE_ROWS_CAMERAS = (4.0, 3.0, 3.0)
"""Row shares of the left column with cameras: the 3D scene, the cameras, the state lanes."""
_TITLE_PX = 24.0
"""Height of a view's title bar [px]."""


def scene_aspect(column: float, row: float, window: tuple[int, int] = (1280, 720)) -> float:
    """Width / height of the 3D view in a column `column` of the window's width and `row` of
    its height below the viewer's bars (the same in both `WINDOWS`: both are 16:9)."""
    w = column * window[0]
    h = row * (window[1] - _CHROME_PX + _TITLE_PX) - _TITLE_PX
    return w / max(h, 1.0)


_RIGHT_ROWS = (1.6, 5.0, 4.0, 4.0)
"""Row shares of the right column: the result (one line), guards, signals, events."""


def _raw_value_views(guards: Sequence[str]) -> list[rrb.TimeSeriesView]:
    """One plot per unit of the guards' raw values (`guard_values/<guard>`: the value in the
    guard's colour, its limit in red), the guards it holds in its title. Without declared
    guards, one plot of them all."""
    if not guards:
        return [rrb.TimeSeriesView(name="Guards: raw values", origin=GUARD_VALUES)]
    units: dict[str, list[str]] = {}
    for name in guards:
        units.setdefault(unit_of(name), []).append(name)
    return [
        rrb.TimeSeriesView(
            name=f"{', '.join(names)}{f' [{unit}]' if unit in UNITS.values() else ''} (limit red)",
            origin=GUARD_VALUES,
            contents=[
                entry
                for n in names
                for entry in (f"$origin/{part(n)}/**", f"$origin/{part(n)}_2/**")
            ],  # fmt: skip
            plot_legend=rrb.PlotLegend(visible=False),
        )
        for unit, names in units.items()
    ]
