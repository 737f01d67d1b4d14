"""What the plots are configured to show: peaks kept at any zoom, guards drawn only while active.

Read back from the .rrd with Rerun's reader (`rerun.chunk.RrdReader`: the recording's chunks as
Arrow record batches), never from the recorder's buffers.
"""

from __future__ import annotations

from collections import defaultdict
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import rerun as rr
from rerun.chunk import RrdReader

from orchestrator.engine.result import RunResult
from orchestrator.engine.runner import run_episode
from orchestrator.recording import RerunRecorder

Policy = rr.components.AggregationPolicy
AGGREGATION = "SeriesLines:aggregation_policy"
SCALARS = "Scalars:scalars"
CLEAR = "Clear:is_recursive"
WRIST_FORCE = "/signals/wrist_force_n"
SAMPLES_PER_PIXEL = 8
"""Control ticks per pixel column of the plot: a 10 ms tick and an 80 ms pixel are a 40 s run in
a 500 px wide plot, a common case (a 3 s run zoomed out the same)."""


@dataclass
class ActiveGuards:
    """An observer that notes, at each control tick, the names of the guards active then."""

    at: dict[int, set[str]] = field(default_factory=dict)

    def on_start(self, ctx: Any, executor: Any) -> None:
        self.at[ctx.tick] = {g.name for g in executor.active_guards}

    def on_tick(self, ctx: Any, executor: Any) -> None:
        self.at[ctx.tick] = {g.name for g in executor.active_guards}

    def on_end(self, ctx: Any, executor: Any, result: RunResult) -> None:
        pass


@dataclass
class Recorded:
    result: RunResult
    active: dict[int, set[str]]
    static: dict[str, dict[str, Any]]
    temporal: dict[str, list[dict[str, Any]]]
    """Rows per entity in log order, each with its `tick` and the components it holds."""


@pytest.fixture(scope="module")
def recorded(pick_place, tmp_path_factory) -> Recorded:
    path = tmp_path_factory.mktemp("rrd") / "peaks.rrd"
    watcher = ActiveGuards()
    result = run_episode(pick_place, 0, [RerunRecorder(path=path), watcher])
    static, temporal = _read(path)
    return Recorded(result, watcher.at, static, temporal)


def _read(path: Path) -> tuple[dict[str, dict], dict[str, list[dict]]]:
    static: dict[str, dict] = defaultdict(dict)
    rows: dict[str, list[tuple[bytes, dict]]] = defaultdict(list)
    for chunk in RrdReader(path).stream().to_chunks():
        for raw in chunk.to_record_batch().to_pylist():
            row_id = raw.pop("rerun.controls.RowId")
            row = {k: v for k, v in raw.items() if v is not None}
            if chunk.is_static:
                static[chunk.entity_path].update(row)
            else:
                rows[chunk.entity_path].append((row_id, row))
    temporal = {e: [r for _, r in sorted(rs, key=lambda x: x[0])] for e, rs in rows.items()}
    return dict(static), temporal


def shown_peak(values: np.ndarray, policy: Policy, per_pixel: int) -> float:
    """The highest point a line of `values` (one per tick) is drawn at when `per_pixel`
    samples share a pixel column and the viewer aggregates them by `policy`."""
    n = len(values) // per_pixel * per_pixel
    columns = values[:n].reshape(-1, per_pixel)
    tail = values[n:]
    if policy is Policy.Off:
        return float(values.max())
    if policy is Policy.Average:
        drawn = columns.mean(axis=1)
        return float(max(drawn.max(), tail.mean() if len(tail) else -np.inf))
    if policy is Policy.Min:
        return float(max(columns.min(axis=1).max(), tail.min() if len(tail) else -np.inf))
    if policy is Policy.MinMaxAverage:
        drawn = (columns.min(axis=1) + columns.max(axis=1)) / 2
        last = (tail.min() + tail.max()) / 2 if len(tail) else -np.inf
        return float(max(drawn.max(), last))
    return float(values.max())  # Max and MinMax keep each column's largest value


def configured_policy(static: dict[str, Any]) -> Policy:
    """The aggregation a series is drawn with: its logged policy, else Rerun's default."""
    logged = static.get(AGGREGATION)
    return Policy(logged[0]) if logged else Policy.Average


def test_the_wrist_force_plot_shows_the_true_peak_when_zoomed_out(recorded):
    true_peak = recorded.result.metrics["max_wrist_force_n"]  # over every physics step
    rows = [r[SCALARS] for r in recorded.temporal[WRIST_FORCE] if SCALARS in r]
    force = np.array(rows)
    assert force.shape[1] == 2 and len(force) > 20 * SAMPLES_PER_PIXEL
    policy = configured_policy(recorded.static[WRIST_FORCE])
    assert policy in (Policy.Max, Policy.MinMax), policy  # each pixel keeps its largest value
    shown = shown_peak(force[:, 1], policy, SAMPLES_PER_PIXEL)
    assert shown == pytest.approx(true_peak, rel=0.01)
    # the peak is a spike: averaged per pixel (Rerun's default) it would not show
    assert shown_peak(force[:, 1], Policy.Average, SAMPLES_PER_PIXEL) < 0.9 * true_peak


def test_every_plotted_series_keeps_its_extremes(recorded):
    series = [e for e, s in recorded.static.items() if "SeriesLines:names" in s]
    assert WRIST_FORCE in series and "/guards/contact_force" in series
    for entity in series:
        if entity == "/guards/trip":  # a constant line at 1.0
            continue
        policy = configured_policy(recorded.static[entity])
        assert policy in (Policy.Max, Policy.MinMax), (entity, policy)
    for entity in series:
        if entity.startswith("/guards/") and entity != "/guards/trip":
            # a margin: its largest value, the nearest the guard came to firing
            assert configured_policy(recorded.static[entity]) is Policy.Max, entity


def _intervals(ticks: list[int]) -> list[tuple[int, int]]:
    """Runs of consecutive control ticks, as (first, last)."""
    out: list[tuple[int, int]] = []
    for t in ticks:
        if out and t == out[-1][1] + 1:
            out[-1] = (out[-1][0], t)
        else:
            out.append((t, t))
    return out


def test_a_guard_is_drawn_only_while_it_is_active(recorded):
    active = recorded.active
    last_tick = max(active)
    guards = {name for names in active.values() for name in names}
    assert "grasp_lost" in guards
    part_time = 0
    for guard in sorted(guards):
        when = sorted(t for t, names in active.items() if guard in names)
        for entity in (f"/guards/{guard}", f"/guard_values/{guard}"):
            rows = recorded.temporal[entity]
            sampled = [r["tick"] for r in rows if SCALARS in r]
            assert sampled, entity
            inactive = sorted(set(sampled) - set(when))
            assert not inactive, f"{entity} sampled while inactive at ticks {inactive[:5]}"
            # the line breaks where the guard stops watching: a clear at the first tick it is
            # no longer active, and no sample after it until the guard is active again
            clears = [r["tick"] for r in rows if CLEAR in r]
            ends = [b + 1 for _, b in _intervals(when) if b < last_tick]
            assert clears == ends, (entity, clears, ends)
            part_time += bool(ends)
    assert part_time >= 2  # grasp_lost (TRANSPORT only) at least, margin and raw value
    grasp = [r["tick"] for r in recorded.temporal["/guards/grasp_lost"] if SCALARS in r]
    assert 0 < len(grasp) < 0.5 * len(active)
