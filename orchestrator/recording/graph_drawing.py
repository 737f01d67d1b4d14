"""The machine graph as Rerun draws it: labels, arrows, frames of nested machines, lit states.

Rerun's graph view draws a labelled node as its text in a frame, the text in the node's colour
(the frame's fill follows the viewer's light or dark theme), and an edge as a straight arrow
between frames. So that every label reads on either theme, idle states are a mid grey and
final states their kind's colour (green, amber, red); the active leaf and the states running
it are lit: an accent colour (finals keep theirs) and `LIT_MARK` before the name.

A view showing more than one graph entity outlines each with a rectangle captioned with its
entity path. The frames of nested machines are exactly that: one entity per nested machine
(`state_machine/graph/PICK/GRASP`) holding two invisible corner points, so that its outline is
the machine's frame and its caption names the nesting; a shut machine's entity holds no
points, and no frame is drawn. Everything a reader follows (states, arrows, outcome labels) is
one entity, `state_machine/graph`: Rerun draws edges only within an entity. Outcome labels are
nodes in a muted blue grey (`EDGE_LABEL`) where Graphviz's `dot` put them (graph_dot.py), and
their arrow runs through them (source -> label -> target): a label is always on its own arrow.
Rerun draws a graph's nodes in order, then its arrows; no two nodes (states, labels, the guard
node) overlap, so an active state is never under another node or label.

Rerun draws an edge straight. An arrow that a straight line would draw through a state or a
label follows `dot`'s route instead (graph_routes.py): it is drawn as a polyline of invisible
points in two entities of their own (`ROUTES`: its pieces but the last, undirected; and
`ROUTE_HEADS`: its last piece, with the arrowhead), from where it leaves its source's box to
where it enters its target's. Rerun outlines and captions these entities too: each also holds
two invisible points far outside the graph (`_OFFSCREEN`), so that their outline lies outside
what the view shows (the blueprint's visual bounds).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

import numpy as np
import rerun as rr
from rerun.chunk import Chunk

from .batches import StaticBatch
from .graph_views import ExpansionView
from .machine_graph import GUARD, LIT_MARK, MachineGraph, on_path
from .paths import GRAPH, ROUTE_HEADS, ROUTES, frame_path
from .timeline import time_columns

__all__ = ["ACCENT", "EDGE_LABEL", "IDLE", "GraphDrawing"]

IDLE = 0x8C8C8CFF
"""Text colour of a state that is not active: legible on the light and the dark theme."""
EDGE_LABEL = 0x7F9AADFF
"""Text colour of the outcomes written on arrows (a muted blue grey: not a state)."""
ACCENT = 0x2F80EDFF
"""Text colour of the active leaf and the states running it (final states keep theirs)."""
_ENTITY_PAD = 10.0
"""Rerun outlines an entity 10 px outside its nodes [px]."""
_CORNER_R = 0.5
"""Radius of a frame's (transparent) corner points [px]."""
_OFFSCREEN = 2.0
"""The route entities' outline lies this many times the graph's larger side outside it (the
view shows at most about one larger side around the graph in a panel of the blueprint)."""


def _rgba(colors: Iterable[int]) -> np.ndarray:
    """0xRRGGBBAA integers as the unambiguous uint32 array Rerun expects."""
    return np.fromiter(colors, dtype=np.uint32)


class GraphDrawing:
    """The graph's expansions over time and, per state entry, which nodes are lit.

    Everything is on the timeline: at each state entry the labels and colours of the nodes
    (the leaf and its ancestors lit); when the entry opens other nested machines than the
    previous one (graph_views.py), also the nodes, their positions, the arrows and the frames.

    Args:
        graph: The machine tree's graph (with its expansions).
    """

    def __init__(self, graph: MachineGraph) -> None:
        self.graph = graph
        self._shown: tuple[str, ...] | None = None
        """The expansion last drawn (None: none yet)."""
        self._owners = sorted({o for o in graph.regions.values() if o})

    def log_static(self, static: StaticBatch) -> None:
        """What never changes: the arrows are directed, labels are shown, frames are
        invisible corner points."""
        static.log(
            GRAPH,
            rr.GraphEdges.from_fields(graph_type="directed"),
            rr.GraphNodes.from_fields(show_labels=True),
        )
        for path, kind in ((ROUTES, "undirected"), (ROUTE_HEADS, "directed")):
            static.log(
                path,
                rr.GraphEdges.from_fields(graph_type=kind),
                rr.GraphNodes.from_fields(show_labels=False),
            )
        for owner in self._owners:
            static.log(
                frame_path(owner),
                rr.GraphNodes.from_fields(
                    colors=_rgba([0, 0]), radii=[_CORNER_R, _CORNER_R], show_labels=False
                ),
            )

    def chunks(
        self, ticks: Sequence[int], t_s: Sequence[float], leaves: Sequence[str]
    ) -> list[Chunk]:
        """The drawing at each state entry (control tick, time [s], the leaf entered)."""
        out: list[Chunk] = []
        layout_rows: list[int] = []
        labels: list[str] = []
        colors: list[int] = []
        lengths: list[int] = []
        for i, leaf in enumerate(leaves):
            view = self.graph.view(leaf)
            if view.expanded != self._shown:
                layout_rows.append(i)
                self._shown = view.expanded
            for node in view.nodes:
                labels.append(self._label(node, leaf, view))
                colors.append(self._color(node, leaf))
            lengths.append(len(view.nodes))
        index = time_columns(np.asarray(ticks), np.asarray(t_s))
        out.append(
            Chunk.from_columns(
                GRAPH,
                indexes=index,
                columns=rr.GraphNodes.columns(labels=labels, colors=_rgba(colors)).partition(
                    lengths
                ),
            )
        )
        if layout_rows:
            out += self._layouts(
                [ticks[i] for i in layout_rows],
                [t_s[i] for i in layout_rows],
                [leaves[i] for i in layout_rows],
            )
        return out

    def _label(self, node: str, leaf: str, view: ExpansionView) -> str:
        text = view.labels[node]
        info = self.graph.states.get(node)
        return LIT_MARK + text if info is not None and on_path(node, leaf) else text

    def _color(self, node: str, leaf: str) -> int:
        info = self.graph.states.get(node)
        if info is None:
            return IDLE if node == GUARD else EDGE_LABEL
        if info.kind in ("success", "final", "abort"):
            return info.color
        return ACCENT if on_path(node, leaf) else IDLE

    def _layouts(
        self, ticks: Sequence[int], t_s: Sequence[float], leaves: Sequence[str]
    ) -> list[Chunk]:
        """Nodes, positions, arrows and frames of the expansions entered at these rows."""
        views = [self.graph.view(leaf) for leaf in leaves]
        index = time_columns(np.asarray(ticks), np.asarray(t_s))
        ids = [n for v in views for n in v.nodes]
        positions = [v.layout.positions[n] for v in views for n in v.nodes]
        edges = [e for v in views for e in v.straight_edges]
        out = [
            Chunk.from_columns(
                GRAPH,
                indexes=index,
                columns=[
                    *rr.GraphNodes.columns(node_ids=ids, positions=positions).partition(
                        [len(v.nodes) for v in views]
                    ),
                    *rr.GraphEdges.columns(edges=edges).partition(
                        [len(v.straight_edges) for v in views]
                    ),
                ],
            )
        ]
        out += self._routes(views, index)
        inset = _ENTITY_PAD + _CORNER_R
        for owner in self._owners:
            corner_ids: list[str] = []
            corners: list[tuple[float, float]] = []
            lengths = []
            for v in views:
                frame = v.layout.groups.get(owner)
                if frame is None:
                    lengths.append(0)
                    continue
                x0, y0, x1, y1 = frame
                corner_ids += ["top_left", "bottom_right"]
                corners += [(x0 + inset, y0 + inset), (x1 - inset, y1 - inset)]
                lengths.append(2)
            out.append(
                Chunk.from_columns(
                    frame_path(owner),
                    indexes=index,
                    columns=rr.GraphNodes.columns(
                        node_ids=corner_ids, positions=np.array(corners).reshape(-1, 2)
                    ).partition(lengths),
                )
            )
        return out

    def _routes(self, views: Sequence[ExpansionView], index: list) -> list[Chunk]:
        """The bent arrows of these expansions: their pieces in `ROUTES` and `ROUTE_HEADS`."""
        x0, y0, x1, y1 = self.graph.bounds
        far = _OFFSCREEN * max(x1 - x0, y1 - y0)
        corners = {"outline_0": (x0 - far, y0 - far), "outline_1": (x1 + far, y1 + far)}
        out = []
        for path, heads in ((ROUTES, False), (ROUTE_HEADS, True)):
            ids: list[str] = []
            points: list[tuple[float, float]] = []
            edges: list[tuple[str, str]] = []
            nodes_n, edges_n = [], []
            for v in views:
                mine: dict[str, tuple[float, float]] = {}
                pieces = []
                for a, b in v.routes:
                    line = v.routed_polyline((a, b))
                    names = [f"{a}->{b}#{k}" for k in range(len(line))]
                    mine.update(zip(names, line, strict=True))
                    pairs = list(zip(names, names[1:], strict=False))
                    pieces += pairs[-1:] if heads else pairs[:-1]
                if mine:
                    mine.update(corners)
                ids += list(mine)
                points += list(mine.values())
                edges += pieces
                nodes_n.append(len(mine))
                edges_n.append(len(pieces))
            out.append(
                Chunk.from_columns(
                    path,
                    indexes=index,
                    columns=[
                        *rr.GraphNodes.columns(
                            node_ids=ids,
                            positions=np.array(points, dtype=np.float64).reshape(-1, 2),
                            colors=_rgba([0] * len(ids)),
                            radii=np.full(len(ids), _CORNER_R, dtype=np.float32),
                        ).partition(nodes_n),
                        *rr.GraphEdges.columns(edges=edges).partition(edges_n),
                    ],
                )
            )
        return out
