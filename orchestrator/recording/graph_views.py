"""What the machine graph shows while a given state runs: its own machines open, the others shut.

A machine tree drawn whole does not fit a panel: mobile_search's is ~1550 px tall, and Rerun's
graph view shrinks it until its 12 px labels are ~5 px. The graph therefore shows one
*expansion* at a time: the nested machines that run the active leaf (its composite ancestors)
are open, every other nested machine is one node (`NAME …`). Each expansion has its own layout
by Graphviz's `dot` (graph_dot.py; without it, graph_layout.py's), computed once per machine;
the recording switches between them as the run enters states in other nested machines.

Where a state branches (its arrows lead to more than one state), each arrow carries the
outcomes that take it (merged when several lead to the same state; past two, counted), as a
small label on or beside the arrow; a chain of single arrows needs none. A state with
`retry: N` has a loop labelled `retry N`; guards declared on a state follow its name on its
label's line (a second line made each guarded state of a chain a rank 16 px taller, and the
graphs are shown at the zoom their height allows). Nothing here knows about Rerun.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from .graph_dot import dot_layout
from .graph_layout import CAPTION_H, GraphLayout, Level, label_size, layered_layout
from .graph_routes import Point, exit_point, route

__all__ = ["COLLAPSED", "LIT_MARK", "ExpansionView", "expansion_view", "label_id", "shifted"]

LIT_MARK = "▶ "
"""Put before the label of an active state in the graph (its box is sized for it)."""
COLLAPSED = " …"
"""After the name of a nested machine shown shut."""
_LABEL_GAP = 1.0
"""Least room between an edge label and a node or another label [px]."""
_SPOTS = (0.5, 0.4, 0.6, 0.3, 0.7, 0.22, 0.78, 0.15, 0.85)
"""Where along an edge (0 at its source, 1 at its target) its label may sit, in order."""
_MAX_OUTCOMES = 2
"""Outcomes written on one arrow; more are counted (`not_homed +3`)."""


def label_id(src: str, dst: str) -> str:
    """Node id of the label on the edge `src` -> `dst`."""
    return f":label:{src}->{dst}"


@dataclass(frozen=True)
class ExpansionView:
    """The graph as drawn with the nested machines in `expanded` open.

    Attributes:
        expanded: The composite states shown open (sorted).
        states: The state node ids drawn (states of open machines, shut machines as one).
        labels: Node id -> its text (states, the guard node and edge labels), unlit.
        edges: The arrows, (source, target) node ids; a retry is a self edge.
        edge_labels: Label node ids, in the order of `edges` that have one.
        layout: Positions and sizes of every node (edge labels included), frames of the open
            nested machines.
        routes: Drawn arrow (`drawn_edges`) -> its bends, for the arrows a straight line would
            draw through a box: they follow `dot`'s route (graph_routes.py).
    """

    expanded: tuple[str, ...]
    states: list[str]
    labels: dict[str, str]
    edges: list[tuple[str, str]]
    edge_labels: list[str]
    layout: GraphLayout
    routes: dict[tuple[str, str], list[Point]] = field(default_factory=dict)

    @property
    def straight_edges(self) -> list[tuple[str, str]]:
        """The drawn arrows that are straight lines between their nodes (not `routes`)."""
        return [e for e in self.drawn_edges if e not in self.routes]

    def routed_polyline(self, edge: tuple[str, str]) -> list[Point]:
        """A routed arrow as drawn: from where it leaves its source's box, through its bends,
        to where it enters its target's box."""
        (a, b), bends = edge, self.routes[edge]
        pos = self.layout.positions
        start = exit_point(pos[a], bends[0], _rect(pos[a], self.room(a)))
        end = exit_point(pos[b], bends[-1], _rect(pos[b], self.room(b)))
        return [start, *bends, end]

    def room(self, node: str) -> tuple[float, float]:
        """The box a node takes, lit or not (w, h) [px]."""
        w, h = self.layout.sizes[node]
        if node in self.states:
            w = max(w, label_size(LIT_MARK + self.labels[node])[0])
        return w, h

    @property
    def drawn_edges(self) -> list[tuple[str, str]]:
        """The arrows as Rerun draws them (straight lines between node ids): an edge with a
        label runs through it, source -> label -> target, so that the label is on its own
        arrow, where `dot` routed the edge, and the arrow goes round what `dot` routed it
        round."""
        out: list[tuple[str, str]] = []
        labelled = set(self.edge_labels)
        for src, dst in self.edges:
            node = label_id(src, dst)
            out += [(src, node), (node, dst)] if node in labelled else [(src, dst)]
        return out

    @property
    def nodes(self) -> list[str]:
        """Every node id: states (and the guard node) first, then edge labels."""
        return [*self.states, *self.edge_labels]


def _representative(state: str, expanded: set[str], composites: set[str]) -> str:
    """The node that stands for `state`: itself, or the outermost shut machine holding it."""
    parts = state.split(".")
    for i in range(1, len(parts)):
        owner = ".".join(parts[:i])
        if owner in composites and owner not in expanded:
            return owner
    return state


def expansion_view(
    top: Level,
    names: dict[str, str],
    composites: set[str],
    outcomes: dict[tuple[str, str], list[str]],
    retries: dict[str, int],
    guards: dict[str, list[str]],
    captions: dict[str, str],
    expanded: tuple[str, ...],
    use_dot: bool = True,
) -> ExpansionView:
    """Lay out the graph with the machines of `expanded` open.

    Args:
        top: The whole tree's top level (nested levels of every composite state).
        names: Node id -> the name it shows (states and the guard node).
        composites: The states that run nested machines.
        outcomes: Every arrow of the whole tree (exits from final states, entries into
            nested machines, the guard's) -> the outcomes that take it (empty: no label).
        retries: State -> its `retry` count (states without one absent).
        guards: State -> the names of the guards declared on it.
        captions: Composite state -> the caption above its frame.
        expanded: The composite states to show open.
        use_dot: Lay out with Graphviz's `dot` (graph_dot.py) when it is installed; else,
            or when it fails, with graph_layout.py.
    """
    open_ = set(expanded)
    level = _pruned(top, open_)
    shown = _nodes(level)
    labels = {}
    for node in shown:
        text = names[node] + (COLLAPSED if node in composites and node not in open_ else "")
        if guards.get(node):
            text += "  guards: " + ", ".join(guards[node])
        labels[node] = text
    merged: dict[tuple[str, str], list[str]] = {}
    for (src, dst), outs in outcomes.items():
        a = _representative(src, open_, composites)
        b = _representative(dst, open_, composites)
        if a == b:
            continue
        into = merged.setdefault((a, b), [])
        into += [o for o in outs if o not in into]
    for state, n in retries.items():
        if state in shown:
            merged.setdefault((state, state), []).append(f"retry {n}")
    branching = {
        a for a, b in merged if a != b and sum(1 for s, d in merged if s == a and d != s) > 1
    }
    texts: dict[tuple[str, str], str | None] = {}
    for (src, dst), outs in merged.items():
        texts[(src, dst)] = None
        if outs and (src == dst or src in branching):
            texts[(src, dst)] = ", ".join(outs[:_MAX_OUTCOMES])
            if len(outs) > _MAX_OUTCOMES:
                texts[(src, dst)] = (
                    f"{', '.join(outs[: _MAX_OUTCOMES - 1])} +{len(outs) - _MAX_OUTCOMES + 1}"
                )
    shown_captions = {o: c for o, c in captions.items() if o in open_}
    lit = {n: LIT_MARK + t for n, t in labels.items()}
    by_dot = dot_layout(level, labels, lit, texts, shown_captions) if use_dot else None
    if by_dot is not None:
        layout, spots, splines = by_dot.layout, by_dot.edge_labels, by_dot.splines
    else:
        layout, spots, splines = layered_layout(level, labels, shown_captions), {}, {}
    edges = list(merged)
    edge_labels: list[str] = []
    positions, sizes = dict(layout.positions), dict(layout.sizes)
    nodes = [_rect(positions[n], sizes[n]) for n in shown]
    taken = [(x0, y0 - CAPTION_H, x0 + layout.captions.get(o, 0.0), y0)
              for o, (x0, y0, _, _) in layout.groups.items()]  # fmt: skip
    for (src, dst), outcome_text in texts.items():
        if outcome_text is None:
            continue
        node = label_id(src, dst)
        size = label_size(outcome_text)
        spot = spots.get((src, dst)) or _place(
            positions[src], sizes[src], positions[dst], sizes[dst], size, nodes, taken
        )
        labels[node] = outcome_text
        positions[node] = spot
        sizes[node] = size
        taken.append(_rect(spot, size))
        edge_labels.append(node)
    placed = GraphLayout(positions, layout.groups, sizes, layout.captions)
    view = ExpansionView(tuple(sorted(open_)), shown, labels, edges, edge_labels, placed)
    view.routes.update(_routes(view, splines))
    return view


def _routes(
    view: ExpansionView, splines: dict[tuple[str, str], list[Point]]
) -> dict[tuple[str, str], list[Point]]:
    """The bends of every drawn arrow of `view` that a straight line would draw through a box
    (a state's lit or not, a label's), along `dot`'s spline of its edge (an edge through its
    label: the spline split where it passes the label)."""
    pos = view.layout.positions
    rects = {n: _rect(pos[n], view.room(n)) for n in view.nodes}
    labelled = set(view.edge_labels)
    out: dict[tuple[str, str], list[Point]] = {}
    for src, dst in view.edges:
        spline = splines.get((src, dst))
        if src == dst or not spline:
            continue
        if math.dist(spline[0], pos[dst]) < math.dist(spline[0], pos[src]):
            spline = spline[::-1]
        node = label_id(src, dst)
        if node in labelled:
            k = min(range(len(spline)), key=lambda i: math.dist(spline[i], pos[node]))
            pieces = [((src, node), spline[: k + 1]), ((node, dst), spline[k:])]
        else:
            pieces = [((src, dst), spline)]
        for (a, b), points in pieces:
            boxes = [r for n, r in rects.items() if n not in (a, b)]
            bends = route(pos[a], pos[b], points, boxes, (rects[a], rects[b]))
            if bends:
                out[(a, b)] = bends
    return out


def _pruned(level: Level, open_: set[str]) -> Level:
    """`level` with the nested levels of shut machines left out."""
    return Level(
        list(level.nodes),
        list(level.edges),
        level.initial,
        {n: [_pruned(lv, open_) for lv in lvs] for n, lvs in level.nested.items() if n in open_},
        list(level.exits),
    )


def _nodes(level: Level) -> list[str]:
    out = list(level.nodes)
    for levels in level.nested.values():
        for lv in levels:
            out += _nodes(lv)
    return out


Rect = tuple[float, float, float, float]


def _rect(center: tuple[float, float], size: tuple[float, float]) -> Rect:
    (x, y), (w, h) = center, size
    return (x - w / 2, y - h / 2, x + w / 2, y + h / 2)


def _place(
    src: tuple[float, float],
    src_size: tuple[float, float],
    dst: tuple[float, float],
    dst_size: tuple[float, float],
    size: tuple[float, float],
    nodes: list[Rect],
    taken: list[Rect],
) -> tuple[float, float]:
    """Where the label of the edge src -> dst goes: on the straight line Rerun draws, at the
    first of `_SPOTS` where it overlaps nothing (a self edge: beside its loop, above the node's
    top right, or left)."""
    if src == dst:
        x, y = src
        w, h = src_size
        spots = [(x + 30 + size[0] / 2, y - h / 2 - 22), (x - 30 - size[0] / 2, y - h / 2 - 22)]
    else:
        (ax, ay), (bx, by) = src, dst
        on_line = [(ax + t * (bx - ax), ay + t * (by - ay)) for t in _SPOTS]
        # then beside the line, left and right of it (a label next to its arrow)
        side = size[0] / 2 + 4.0
        spots = on_line + [
            (x + d, y) for d in (side, -side, side + 24.0, -side - 24.0) for x, y in on_line
        ]
    best, least = spots[0], math.inf
    for spot in spots:
        box = _rect(spot, size)
        # covering a state's name is worse than covering another label
        covered = 4.0 * sum(_area(box, r) for r in nodes) + sum(_area(box, r) for r in taken)
        if covered == 0.0:
            return spot
        if covered < least:
            best, least = spot, covered
    return best


def _area(a: Rect, b: Rect) -> float:
    """How much of `a` (grown by the gap) overlaps `b` [px^2]."""
    g = _LABEL_GAP
    w = min(a[2] + g, b[2]) - max(a[0] - g, b[0])
    h = min(a[3] + g, b[3]) - max(a[1] - g, b[1])
    return w * h if w > 0 and h > 0 else 0.0


def shifted(view: ExpansionView, dx: float, dy: float) -> ExpansionView:
    """`view` moved by (dx, dy) [px]."""
    lay = view.layout
    layout = GraphLayout(
        {n: (x + dx, y + dy) for n, (x, y) in lay.positions.items()},
        {n: (a + dx, b + dy, c + dx, d + dy) for n, (a, b, c, d) in lay.groups.items()},
        lay.sizes,
        lay.captions,
    )
    routes = {e: [(x + dx, y + dy) for x, y in bends] for e, bends in view.routes.items()}
    return ExpansionView(
        view.expanded, view.states, view.labels, view.edges, view.edge_labels, layout, routes
    )
