"""The default layout: raw guard values one plot per unit, no legend on the data."""

from __future__ import annotations

import pytest
import rerun.blueprint as rrb

from orchestrator.recording.blueprint import (
    _LEGEND_PAD_PX,
    _LEGEND_ROW_PX,
    _MARGINS_PLOT_PX,
    _MARGINS_TOP,
    _raw_value_views,
    default_blueprint,
    margins_legend_rows,
    margins_range,
)
from orchestrator.recording.guard_margins import UNITS, unit_of


def test_raw_guard_values_get_one_plot_per_unit():
    guards = ["contact_force", "workspace", "joint_limits", "no_go_zone", "sensor_health", "odd"]
    views = _raw_value_views(guards)
    assert len(views) == len({unit_of(g) for g in guards}) == 4
    for view in views:
        shown = {c.split("/")[1] for c in view.contents}
        held = [g for g in guards if g in shown]
        assert held and len({unit_of(g) for g in held}) == 1, (view.name, held)
        unit = unit_of(held[0])
        assert (f"[{unit}]" in view.name) == (unit in UNITS.values())
        assert all(g in view.name for g in held)
    every = {c.split("/")[1] for v in views for c in v.contents}
    assert set(guards) <= every
    # a second guard of the same name (`<name>_2`) goes with its unit
    assert unit_of("contact_force_2") == "N" and unit_of("odd_2") == "odd_2"


@pytest.mark.parametrize("n_guards", range(0, 12))
def test_the_margins_legend_never_lies_on_the_trip_line(n_guards):
    lo, hi = margins_range(n_guards)
    assert lo == 0.0 and hi >= _MARGINS_TOP > 1.0
    rows = margins_legend_rows(n_guards)
    if rows:  # the legend's height in the smaller window fits above the data's top
        legend_px = rows * _LEGEND_ROW_PX + _LEGEND_PAD_PX
        above_px = (hi - _MARGINS_TOP) / hi * _MARGINS_PLOT_PX
        assert legend_px <= above_px + 1e-9
    else:  # too many guards for the room: hidden, the axis is the data's
        assert hi == pytest.approx(_MARGINS_TOP)
    assert margins_legend_rows(2) == 3  # a typical run's two guards keep their legend


def test_the_layout_has_the_result_panel_and_no_legend_over_the_force_plots():
    blueprint = default_blueprint(guards=["contact_force", "workspace"])
    views = []

    def walk(item):
        if isinstance(item, rrb.Blueprint):
            walk(item.root_container)
        elif hasattr(item, "contents") and isinstance(item, rrb.Container):
            for child in item.contents:
                walk(child)
        else:
            views.append(item)

    walk(blueprint)
    kinds = {type(v).__name__ for v in views}
    assert "TextDocumentView" in kinds
    series = {v.name: v for v in views if isinstance(v, rrb.TimeSeriesView)}

    def legend_shown(view: rrb.TimeSeriesView) -> bool:
        legend = view.properties.get("PlotLegend")
        if legend is None or legend.visible is None:
            return True  # Rerun's default: a legend
        return bool(legend.visible.as_arrow_array().to_pylist()[0])

    force = [v for name, v in series.items() if name.startswith(("Wrist", "Force"))]
    raw = [v for name, v in series.items() if "(limit red)" in name]
    assert len(force) == 2 and len(raw) == 2  # N and m
    assert not any(legend_shown(v) for v in force + raw)  # their lines are named in titles
    margins = next(v for name, v in series.items() if name.startswith("Guards: margin"))
    assert legend_shown(margins)  # two guards: the legend fits above the trip line
