"""The machine graph as logged: laid out by Graphviz's `dot`, nothing drawn over anything else.

Each bundled machine's graph is logged as the recorder logs it while the machine enters every
one of its leaf states in turn, so every nested machine is shown open and every state lit once;
the .rrd is read back with Rerun's reader (`rerun.chunk.RrdReader`), and the boxes Rerun draws
(each node's label in its frame, each nested machine's caption above its frame) are rebuilt
from the logged positions and texts.
"""

from __future__ import annotations

import os
import shutil
from collections import defaultdict
from pathlib import Path

import pytest
import rerun as rr
from rerun.chunk import RrdReader

from orchestrator.language.bundled import bundled_names
from orchestrator.language.load import load_machine
from orchestrator.recording.batches import StaticBatch
from orchestrator.recording.blueprint import (
    WINDOWS,
    graph_panel_px,
    graph_zoom,
    machine_share,
)
from orchestrator.recording.graph_drawing import _CORNER_R, _ENTITY_PAD
from orchestrator.recording.graph_layout import CAPTION_H, label_size
from orchestrator.recording.graph_routes import crosses
from orchestrator.recording.graph_views import LIT_MARK, label_id
from orchestrator.recording.machine_graph import build_graph
from orchestrator.recording.paths import GRAPH, ROUTE_HEADS, ROUTES
from orchestrator.recording.state_log import StateLog

REQUIRE_DOT = "ORCHESTRATOR_REQUIRE_DOT"
"""Set by CI (.ci/run installs Graphviz): without `dot` these tests then fail, not skip."""
needs_dot = pytest.mark.skipif(
    shutil.which("dot") is None and not os.environ.get(REQUIRE_DOT),
    reason=f"Graphviz's dot not installed (set {REQUIRE_DOT}=1 to make that a failure)",
)

Box = tuple[str, float, float, float, float]
_SLACK = 40.0
"""More than the room the view keeps around the graph's bounds [px]."""


def _log_every_leaf(name: str, path: Path) -> list[str]:
    """Record the graph of machine `name` entering each of its leaf states, one per tick."""
    graph = build_graph(load_machine(name))
    owners = set(graph.regions.values())
    leaves = [p for p in graph.states if p not in owners]
    log = StateLog(graph)
    static = StaticBatch()
    log.log_static(static)
    for tick, leaf in enumerate(leaves):
        log.enter(tick, tick * 0.01, leaf)
    rec = rr.RecordingStream("graph_layout", send_properties=False)
    rec.save(path)
    rec.send_chunks(static.chunks())
    rec.send_chunks(log.chunks())
    rec.disconnect()
    return leaves


def _rows(path: Path) -> dict[str, list[dict]]:
    """Temporal rows per entity, one per tick in tick order, with every component logged at
    that tick (the labels and the layout of one entry travel in different chunks)."""
    rows: dict[str, dict[int, dict]] = defaultdict(dict)
    for chunk in RrdReader(path).stream().to_chunks():
        if chunk.is_static:
            continue
        for raw in chunk.to_record_batch().to_pylist():
            row = {k: v for k, v in raw.items() if v is not None}
            rows[chunk.entity_path].setdefault(row["tick"], {}).update(row)
    return {e: [r[t] for t in sorted(r)] for e, r in rows.items()}


def _drawn(rows: dict[str, list[dict]]) -> list[tuple[int, list[Box]]]:
    """Per logged state entry: every box Rerun draws in the graph view then."""
    ids: list[str] = []
    positions: list[list[float]] = []
    frames: dict[str, list[list[float]]] = {}
    out = []
    frame_rows = {
        e: {r["tick"]: r for r in rs}
        for e, rs in rows.items()
        if e.startswith(f"/{GRAPH}/") and e not in (f"/{ROUTES}", f"/{ROUTE_HEADS}")
    }
    for row in rows[f"/{GRAPH}"]:
        if "GraphNodes:node_ids" in row:
            ids, positions = row["GraphNodes:node_ids"], row["GraphNodes:positions"]
            for entity, by_tick in frame_rows.items():
                if row["tick"] in by_tick:
                    frames[entity] = by_tick[row["tick"]].get("GraphNodes:positions") or []
        labels = row["GraphNodes:labels"]
        assert len(labels) == len(ids) == len(positions)
        boxes = []
        for node, (x, y), text in zip(ids, positions, labels, strict=True):
            w, h = label_size(text)
            boxes.append((node, x - w / 2, y - h / 2, x + w / 2, y + h / 2))
        # Rerun outlines the graph entity too (10 px outside its nodes) and writes its path
        # above the outline's top left, as it does for every frame
        x0 = min(b[1] for b in boxes) - _ENTITY_PAD
        y0 = min(b[2] for b in boxes) - _ENTITY_PAD
        w = label_size(f"/{GRAPH}")[0]
        boxes.append((f"caption /{GRAPH}", x0, y0 - CAPTION_H, x0 + w, y0))
        inset = _ENTITY_PAD + _CORNER_R
        for entity, corners in frames.items():
            if corners:  # Rerun writes the entity path above the frame's outline
                x0, y0 = corners[0][0] - inset, corners[0][1] - inset
                w = label_size(entity)[0]
                boxes.append((f"caption {entity}", x0, y0 - CAPTION_H, x0 + w, y0))
        out.append((row["tick"], boxes))
    return out


def _overlaps(boxes: list[Box]) -> list[tuple[str, str]]:
    return [
        (a[0], b[0])
        for i, a in enumerate(boxes)
        for b in boxes[i + 1 :]
        if a[1] < b[3] and b[1] < a[3] and a[2] < b[4] and b[2] < a[4]
    ]


@needs_dot
@pytest.mark.parametrize("name", bundled_names("machines"))
def test_no_node_or_label_overlaps_another_in_any_logged_layout(name, tmp_path):
    leaves = _log_every_leaf(name, tmp_path / "graph.rrd")
    drawn = _drawn(_rows(tmp_path / "graph.rrd"))
    assert [tick for tick, _ in drawn] == list(range(len(leaves)))
    graph = build_graph(load_machine(name))
    for tick, boxes in drawn:
        leaf = leaves[tick]
        names = {b[0] for b in boxes}
        assert leaf in names  # the active leaf is drawn, lit, in every layout
        overlaps = _overlaps(boxes)
        assert not overlaps, (name, leaf, overlaps[:5])
        # every nested machine holding the leaf is open: its frame and caption are drawn
        for owner in graph.expansion(leaf):
            assert any(b[0].startswith("caption") and b[0].endswith(owner.replace(".", "/"))
                       for b in boxes), (leaf, owner)  # fmt: skip


def _box_of(x: float, y: float, text: str) -> tuple[float, float, float, float]:
    w, h = label_size(text)
    return x - w / 2, y - h / 2, x + w / 2, y + h / 2


def _arrows(rows: dict[str, list[dict]]) -> list[tuple[int, dict, list, list]]:
    """Per logged layout: the node boxes (id -> box), the straight arrows as segments with
    the nodes they join, and the bent arrows' pieces (segments of the route entities)."""
    routes = {e: {r["tick"]: r for r in rows.get(f"/{e}", [])} for e in (ROUTES, ROUTE_HEADS)}
    out = []
    for row in rows[f"/{GRAPH}"]:
        if "GraphNodes:node_ids" not in row:
            continue
        pos = dict(zip(row["GraphNodes:node_ids"], row["GraphNodes:positions"], strict=True))
        texts = dict(zip(row["GraphNodes:node_ids"], row["GraphNodes:labels"], strict=True))
        boxes = {n: _box_of(*pos[n], texts[n]) for n in pos}
        straight = [(pos[e["first"]], pos[e["second"]], (e["first"], e["second"]))
                    for e in row.get("GraphEdges:edges") or []]  # fmt: skip
        pieces = []
        for entity in (ROUTES, ROUTE_HEADS):
            r = routes[entity].get(row["tick"], {})
            ids, points = r.get("GraphNodes:node_ids") or [], r.get("GraphNodes:positions") or []
            at = dict(zip(ids, points, strict=True))
            pieces += [(at[e["first"]], at[e["second"]], entity)
                       for e in r.get("GraphEdges:edges") or []]  # fmt: skip
        out.append((row["tick"], boxes, straight, pieces))
    return out


@needs_dot
@pytest.mark.parametrize("name", bundled_names("machines"))
def test_no_arrow_runs_through_a_state_or_a_label_in_any_logged_layout(name, tmp_path):
    # Rerun draws each edge straight: an arrow a straight line would draw through a box
    # follows dot's route, bent at invisible points (graph_routes.py)
    _log_every_leaf(name, tmp_path / "graph.rrd")
    layouts = _arrows(_rows(tmp_path / "graph.rrd"))
    assert layouts
    bent = 0
    for tick, boxes, straight, pieces in layouts:
        for a, b, ends in straight:
            if ends[0] == ends[1]:
                continue  # a retry's loop
            through = [n for n, r in boxes.items() if n not in ends and crosses(a, b, [r])]
            assert not through, (name, tick, ends, through)
        for a, b, entity in pieces:
            # a piece starts and ends outside every box, its own ends' included
            through = [n for n, r in boxes.items() if crosses(a, b, [r])]
            assert not through, (name, tick, entity, a, b, through)
        bent += sum(1 for *_, entity in pieces if entity == ROUTE_HEADS)
    if name in ("pick_place", "sorting", "sorting_conveyor", "mobile_search"):
        assert bent > 0  # these graphs have arrows dot routes round states


@needs_dot
def test_every_arrow_is_drawn_once_straight_or_bent_with_one_head(tmp_path):
    leaves = _log_every_leaf("sorting_conveyor", tmp_path / "graph.rrd")
    graph = build_graph(load_machine("sorting_conveyor"))
    layouts = _arrows(_rows(tmp_path / "graph.rrd"))
    shown = [graph.view(leaf).expanded for leaf in leaves]
    firsts = [i for i, key in enumerate(shown) if i == 0 or shown[i - 1] != key]
    assert [tick for tick, *_ in layouts] == firsts
    for tick, _, straight, pieces in layouts:
        view = graph.view(leaves[tick])
        heads = [p for p in pieces if p[2] == ROUTE_HEADS]
        assert len(straight) + len(heads) == len(view.drawn_edges)
        assert {e for *_, e in straight} == set(view.drawn_edges) - set(view.routes)


@needs_dot
@pytest.mark.parametrize("name", ["pick_place", "sorting_conveyor", "mobile_search"])
def test_the_route_entities_outline_lies_outside_what_the_view_shows(name, tmp_path):
    # Rerun outlines every graph entity of a view holding several: the bent arrows' entities
    # hold two invisible points far out, so that outline stays out of the shown area
    _log_every_leaf(name, tmp_path / "graph.rrd")
    rows = _rows(tmp_path / "graph.rrd")
    graph = build_graph(load_machine(name))
    bounds = graph.bounds
    share = machine_share(bounds)
    for entity in (ROUTES, ROUTE_HEADS):
        for row in rows[f"/{entity}"]:
            points = row.get("GraphNodes:positions") or []
            if not points:
                continue
            x0, y0 = min(p[0] for p in points), min(p[1] for p in points)
            x1, y1 = max(p[0] for p in points), max(p[1] for p in points)
            for window in WINDOWS:
                zoom = graph_zoom(bounds, share, window)
                pw, ph = graph_panel_px(share, window)
                # the view centres the shown bounds (the layout and the room around it)
                cx, cy = (bounds[0] + bounds[2]) / 2, (bounds[1] + bounds[3]) / 2
                vw, vh = pw / zoom / 2 + _SLACK, ph / zoom / 2 + _SLACK
                assert x0 < cx - vw and x1 > cx + vw and y0 < cy - vh and y1 > cy + vh


@needs_dot
def test_the_lit_state_is_sized_in_and_every_edge_label_is_on_its_arrow(tmp_path):
    # the layout leaves room for the lit mark: a lit label is wider than its unlit box
    leaves = _log_every_leaf("pick_place", tmp_path / "graph.rrd")
    rows = _rows(tmp_path / "graph.rrd")[f"/{GRAPH}"]
    lit = [row["GraphNodes:labels"] for row in rows]
    assert all(any(t.startswith(LIT_MARK) for t in labels) for labels in lit)
    # an arrow with a label runs through it: source -> label -> target
    graph = build_graph(load_machine("pick_place"))
    view = graph.view(leaves[0])
    assert view.edge_labels
    for node in view.edge_labels:
        src, dst = next(e for e in view.edges if label_id(*e) == node)
        assert (src, node) in view.drawn_edges and (node, dst) in view.drawn_edges
        assert (src, dst) not in view.drawn_edges


def test_without_dot_the_built_in_layout_is_used_with_one_warning(monkeypatch):
    from orchestrator.recording import graph_dot

    monkeypatch.setattr(graph_dot.shutil, "which", lambda _: None)
    with pytest.warns(RuntimeWarning, match="dot") as caught:
        graph = build_graph(load_machine("pick_place"))
    assert len(caught) == 1  # one line per machine graph, not one per expansion
    view = graph.view(graph.initial_leaf)
    assert set(view.states) <= set(view.layout.positions)
    boxes = [
        (n, x - w / 2, y - h / 2, x + w / 2, y + h / 2)
        for n in view.states
        for (x, y), (w, h) in [(view.layout.positions[n], view.layout.sizes[n])]
    ]
    assert not _overlaps(boxes)
