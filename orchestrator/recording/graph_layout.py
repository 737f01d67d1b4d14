"""A layered (Sugiyama) layout of a nested machine for Rerun's graph view, when Graphviz's
`dot` is not installed (graph_dot.py lays the graph out with `dot` otherwise).

Rerun's graph view draws nodes where it is told (`GraphNodes(positions=...)`); without
positions it runs a force simulation, which turns a state machine into a tangle. This module
computes the positions once per machine: each machine level is laid out top to bottom in flow
order with `grandalf`'s Sugiyama layout (layers by longest path from the initial state,
crossings reduced, Brandes-Köpf coordinates), and a state that runs nested machines becomes
one large node of its level, sized to hold its own layout, a header for its name and a
margin. Nothing here knows about Rerun or the simulator.

Coordinates are the graph view's scene units: x to the right, y down, one unit one screen
pixel at zoom 1 (the view fits the whole graph in its panel, and never zooms in past 1).
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Callable
from dataclasses import dataclass, field

from grandalf.graphs import Edge, Vertex, graph_core
from grandalf.layouts import SugiyamaLayout

from .graph_loops import feedback_edges

__all__ = ["CAPTION_H", "FONT_PX", "GraphLayout", "Level", "label_size", "layered_layout"]

FONT_PX = 12.0
"""Text size of Rerun's graph-view labels at zoom 1 [px]."""
_PAD_X, _PAD_Y = 6.0, 4.0
"""Inner margin of a label's frame in Rerun's graph view [px]."""
_LINE_H = 16.0
"""Height of one line of label text [px]."""
_WIDTHS = {
    " ": 0.30, ".": 0.30, ",": 0.30, ":": 0.30, "_": 0.55, "I": 0.32, "-": 0.40, "▶": 0.85,
    "…": 1.0, "i": 0.25, "l": 0.25, "t": 0.35, "f": 0.35, "r": 0.38, "m": 0.85, "w": 0.75,
}  # fmt: skip
_UPPER, _WIDE, _LOWER = 0.70, 1.0, 0.52
"""Advance widths of the narrow characters of Rerun's UI font (Inter), in ems."""
_XSPACE, _YSPACE = 28.0, 21.0
"""Gaps between neighbours in a layer and between layers [px]: a row of edge labels (26 px
high) fits between two layers. A lit label (`▶ ` before the name, ~15 px wider, centred)
still leaves neighbours ~16 px apart: only one state per machine level is lit."""
_GROUP_PAD = 8.0
"""Margin inside a group frame around its states [px]."""
CAPTION_H = 18.0
"""Room above a group frame for its caption (Rerun writes an entity's path there) [px]."""
_BRANCH_GAP = 16.0
"""Gap between the parallel branches of one group [px]."""
_COMPONENT_GAP = 36.0
"""Gap between parts of one level that no transition connects [px]."""


def label_size(text: str) -> tuple[float, float]:
    """The size of a node's label frame in the graph view: width, height [px]. A label may
    have several lines (`\n`).

    An estimate from Inter's advance widths (upper case ~0.70 em, lower case ~0.52 em), within
    ~5% of what Rerun 0.41 draws for upper-case state names (`TRANSPORT`: 90 px drawn, 90 px
    estimated); Rerun measures the real text, and the gaps are larger than the error.
    """
    lines = text.split("\n")
    em = max(sum(_advance(ch) for ch in line) for line in lines)
    return em * FONT_PX + 2 * _PAD_X + 2.0, _LINE_H * len(lines) + 2 * _PAD_Y + 2.0


def _advance(ch: str) -> float:
    if ch in _WIDTHS:
        return _WIDTHS[ch]
    if ch.isupper() or ch.isdigit():
        return _WIDE if ch in "MW" else _UPPER
    return _LOWER


@dataclass
class Level:
    """One machine level to lay out.

    Attributes:
        nodes: Node ids of its states, in declaration order.
        edges: Transitions between its states (source id, target id); a transition into or
            out of a nested machine names the state that runs it.
        initial: The state the level starts in (the top of its layout).
        nested: Node id -> the levels it runs (one nested machine, or parallel branches).
        exits: Nodes with a transition out of the level (the final states of a nested
            machine): the layout keeps the way down from them clear.
    """

    nodes: list[str]
    edges: list[tuple[str, str]]
    initial: str
    nested: dict[str, list[Level]] = field(default_factory=dict)
    exits: list[str] = field(default_factory=list)


@dataclass(frozen=True)
class GraphLayout:
    """Where everything goes.

    Attributes:
        positions: Node id -> centre (x, y) [px]. A state that runs nested machines is its
            group's title, at the top left inside its frame.
        groups: Node id of a state running nested machines -> its frame (x0, y0, x1, y1) [px];
            `CAPTION_H` above the frame is kept free for a caption.
        sizes: Node id -> the estimated size of its label (w, h) [px].
        captions: Group owner -> the estimated width of its frame's caption [px].
    """

    positions: dict[str, tuple[float, float]]
    groups: dict[str, tuple[float, float, float, float]]
    sizes: dict[str, tuple[float, float]]
    captions: dict[str, float] = field(default_factory=dict)

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        """Everything drawn, labels and frames with their captions: (x0, y0, x1, y1) [px]."""
        rects = [
            (x - self.sizes[n][0] / 2, y - self.sizes[n][1] / 2, x + self.sizes[n][0] / 2,
             y + self.sizes[n][1] / 2)
            for n, (x, y) in self.positions.items()
        ]  # fmt: skip
        rects += [
            (x0, y0 - CAPTION_H, max(x1, x0 + self.captions.get(owner, 0.0)), y1)
            for owner, (x0, y0, x1, y1) in self.groups.items()
        ]
        return (
            min(r[0] for r in rects),
            min(r[1] for r in rects),
            max(r[2] for r in rects),
            max(r[3] for r in rects),
        )


@dataclass
class _Placed:
    """A level laid out in its own frame: top-left at (0, 0)."""

    positions: dict[str, tuple[float, float]]
    groups: dict[str, tuple[float, float, float, float]]
    width: float
    height: float

    def shifted(self, dx: float, dy: float) -> _Placed:
        return _Placed(
            {k: (x + dx, y + dy) for k, (x, y) in self.positions.items()},
            {k: (a + dx, b + dy, c + dx, d + dy) for k, (a, b, c, d) in self.groups.items()},
            self.width,
            self.height,
        )


_Segment = tuple[tuple[float, float], tuple[float, float], tuple[str, ...]]
"""A straight line (from, to) and the nodes it joins (their labels are not obstacles)."""


class _View:
    """The size and position grandalf reads and writes on a vertex."""

    def __init__(self, w: float, h: float) -> None:
        self.w, self.h = w, h
        self.xy = (0.0, 0.0)


def layered_layout(
    top: Level, labels: dict[str, str], captions: dict[str, str] | None = None
) -> GraphLayout:
    """Lay out a machine tree: every level top to bottom, nested levels inside their owner.

    Args:
        top: The top level, with its nested levels.
        labels: Node id -> the text its label shows.
        captions: Group owner -> the caption written above its frame (counted in `bounds`).

    Returns:
        The positions, group frames and label sizes; deterministic for the same input.
    """
    sizes = {node: label_size(text) for node, text in labels.items()}
    placed = _place(top, sizes)
    widths = {o: label_size(t)[0] - 2 * _PAD_X for o, t in (captions or {}).items()}
    return GraphLayout(placed.positions, placed.groups, sizes, widths)


def _place(level: Level, sizes: dict[str, tuple[float, float]]) -> _Placed:
    inner: dict[str, _Placed] = {}
    box: dict[str, tuple[float, float]] = {}
    for node in level.nodes:
        if node in level.nested:
            inner[node] = _group(node, level.nested[node], sizes)
            # Rerun's caption above the frame goes into the layer gap above it (18 of 21 px):
            # the layout places the frame (sorting_conveyor 794 -> 776 px tall)
            box[node] = (inner[node].width, inner[node].height - CAPTION_H)
        else:
            box[node] = sizes[node]
    centres = _sugiyama(level, box)
    out = _Placed({}, {}, 0.0, 0.0)
    for node, (cx, cy) in centres.items():
        w, h = box[node]
        if node in inner:
            sub = inner[node].shifted(cx - w / 2, cy - h / 2 - CAPTION_H)
            out.positions.update(sub.positions)
            out.groups.update(sub.groups)
        else:
            out.positions[node] = (cx, cy)
    x0, y0, x1, y1 = _extent(centres, box)
    y0 = min([y0, *(centres[n][1] - box[n][1] / 2 - CAPTION_H for n in inner)])
    out = out.shifted(-x0, -y0)
    out.width, out.height = x1 - x0, y1 - y0
    return out


def _group(owner: str, levels: list[Level], sizes: dict[str, tuple[float, float]]) -> _Placed:
    """A state running nested levels: a caption, then in a frame its title and its levels
    side by side."""
    title_w, title_h = sizes[owner]
    parts = [_place(lv, sizes) for lv in levels]
    frame_top = CAPTION_H
    title = (_GROUP_PAD + title_w / 2, frame_top + _GROUP_PAD + title_h / 2)
    out = _Placed({owner: title}, {}, 0.0, 0.0)
    inner = _Placed({}, {}, 0.0, 0.0)
    x = _GROUP_PAD
    for part in parts:
        sub = part.shifted(x, 0.0)
        inner.positions.update(sub.positions)
        inner.groups.update(sub.groups)
        x += part.width + _BRANCH_GAP
    # the levels start half a label under the title's top when what comes first in them lies
    # clear of the title, to its right (pick_place_vision 819 -> 772 px tall); else below it
    top = frame_top + _GROUP_PAD + title_h + _YSPACE / 2
    raised = frame_top + _GROUP_PAD + title_h / 2
    keep = (_GROUP_PAD + title_w + _XSPACE, frame_top + _GROUP_PAD + title_h + _YSPACE / 2)
    rects = [(cx - sizes[n][0] / 2, cy - sizes[n][1] / 2 + raised)
             for n, (cx, cy) in inner.positions.items()]  # fmt: skip
    rects += [(x0, y0 - CAPTION_H + raised) for x0, y0, _, _ in inner.groups.values()]
    if all(rx >= keep[0] or ry >= keep[1] for rx, ry in rects):
        top = raised
    sub = inner.shifted(0.0, top)
    out.positions.update(sub.positions)
    out.groups.update(sub.groups)
    inner_w = x - _BRANCH_GAP - _GROUP_PAD
    out.width = max(inner_w, title_w) + 2 * _GROUP_PAD
    out.height = top + max(p.height for p in parts) + _GROUP_PAD
    out.groups[owner] = (0.0, frame_top, out.width, out.height)
    return out


def _sugiyama(level: Level, box: dict[str, tuple[float, float]]) -> dict[str, tuple[float, float]]:
    """Centres of the level's nodes; each connected part laid out on its own, the part with
    the initial state first, the others to its right in declaration order, tops aligned."""
    seen: dict[tuple[str, str], None] = {}
    for src, dst in level.edges:
        if src != dst and (src, dst) not in seen and (dst, src) not in seen:
            seen[(src, dst)] = None
    # the connected parts built here, not by grandalf's Graph: it collects a part's edges in a
    # set of objects hashed by address, and the layout then changed from run to run
    part_of = {node: node for node in level.nodes}

    def root(node: str) -> str:
        while part_of[node] != node:
            node = part_of[node]
        return node

    for src, dst in seen:
        a, b = sorted((root(src), root(dst)), key=level.nodes.index)
        part_of[b] = a
    parts = []
    for head in dict.fromkeys(root(n) for n in level.nodes):
        nodes = [n for n in level.nodes if root(n) == head]
        first = 0 if level.initial in nodes else 1
        parts.append(((first, level.nodes.index(head)), nodes))
    centres: dict[str, tuple[float, float]] = {}
    x = 0.0
    for _, nodes in sorted(parts, key=lambda p: p[0]):
        mine = _part_placement(nodes, level, box, sorted(seen))
        left = min(cx - box[n][0] / 2 for n, (cx, _) in mine.items())
        top = min(cy - box[n][1] / 2 for n, (_, cy) in mine.items())
        right = max(cx + box[n][0] / 2 for n, (cx, _) in mine.items())
        local = {n: (cx - left, cy - top) for n, (cx, cy) in mine.items()}
        spot = _free_corner(local, centres, box, sorted(seen)) if centres else None
        dx, dy = spot if spot is not None else (x, 0.0)
        for n, (cx, cy) in local.items():
            centres[n] = (cx + dx, cy + dy)
        if spot is None:
            x += right - left + _COMPONENT_GAP
    return centres


def _part_placement(
    nodes: list[str],
    level: Level,
    box: dict[str, tuple[float, float]],
    edges: list[tuple[str, str]],
) -> dict[str, tuple[float, float]]:
    """One connected part laid out twice, its final states in the layers they fall in and in
    a column at its side (`_ends`): the column if it makes the part narrower and no taller
    (mobile_search's grasp 939 -> 842 px wide, stack's 771 -> 596 px)."""
    ends = _ends(nodes, edges, level)
    options = [_part_layout(_core(nodes, edges, box), level, box, edges, [])]
    if ends:
        rest = [n for n in nodes if n not in ends]
        options.append(_part_layout(_core(rest, edges, box), level, box, edges, ends))

    def size(pos: dict[str, tuple[float, float]]) -> tuple[float, float]:
        x0, y0, x1, y1 = _extent(pos, box)
        return y1 - y0, x1 - x0

    tall = size(options[0])[0]
    return min(options, key=lambda p: (size(p)[0] > tall, size(p)[1]))


def _core(
    nodes: list[str], edges: list[tuple[str, str]], box: dict[str, tuple[float, float]]
) -> graph_core:
    """A grandalf graph of `nodes` and the `edges` between them, each vertex sized."""
    vertices = {node: Vertex(node) for node in nodes}
    for node, v in vertices.items():
        v.view = _View(*box[node])
    joins = [Edge(vertices[s], vertices[d]) for s, d in edges if s in nodes and d in nodes]
    return graph_core(list(vertices.values()), joins)


def _ends(nodes: list[str], edges: list[tuple[str, str]], level: Level) -> list[str]:
    """The states of a connected part that only end it (no transition out within the level:
    final states), when there are several and something else to lay out: they go into a
    column at the part's right (`_end_column`) instead of widening its layers."""
    sources = {s for s, _ in edges}
    ends = [n for n in nodes if n not in sources and n not in level.nested]
    return ends if len(ends) > 1 and len(ends) < len(nodes) else []


def _end_column(
    ends: list[str],
    pos: dict[str, tuple[float, float]],
    box: dict[str, tuple[float, float]],
    edges: list[tuple[str, str]],
    groups: set[str],
) -> dict[str, tuple[float, float]]:
    """Centres of the `ends` among the states at `pos`: each one at least a layer gap below
    the lowest state leading to it (the flow still reads top to bottom), in the first row of
    the room those states take where its label keeps the layout's gaps, no arrow runs through
    it and its own arrows cross no label, nearest the states leading to it; an end with no
    such room goes into a column at the right. In order of that row, then declaration order."""
    placed = dict(pos)
    x0, _, right, bottom = _extent(pos, box)
    column = -math.inf
    mx, my = _XSPACE / 2, _YSPACE / 2

    def feeders(end: str) -> list[str]:
        return [s for s, d in edges if d == end and s in pos]

    def lowest(end: str) -> float:
        feeds = [pos[s][1] + box[s][1] / 2 for s in feeders(end)]
        return max(feeds, default=min(y for _, y in pos.values())) + _YSPACE

    for end in sorted(ends, key=lambda n: (lowest(n), ends.index(n))):
        w, h = box[end]
        srcs = feeders(end)
        want = sum(placed[s][0] for s in srcs) / len(srcs) if srcs else x0 + w / 2
        rects = {n: (cx - box[n][0] / 2 - mx, cy - box[n][1] / 2 - my - CAPTION_H * (n in groups),
                     cx + box[n][0] / 2 + mx, cy + box[n][1] / 2 + my)
                 for n, (cx, cy) in placed.items()}  # fmt: skip
        inner = {n: _shrunk(r, mx, my) for n, r in rects.items()}
        lines = [(placed[s], placed[d]) for s, d in edges if s in placed and d in placed]
        low = lowest(end)
        tops = sorted({low, *(r[3] + my for r in rects.values() if r[3] + my > low)})
        spot, least = None, math.inf
        for top in (t for t in tops if t + h <= max(bottom, tops[0] + h)):
            cy = top + h / 2
            xs = sorted(
                (x0 + w / 2 + 4.0 * i for i in range(int((right - x0 - w) / 4.0) + 1)),
                key=lambda x: (abs(x - want), x),
            )
            for cx in xs:
                r = (cx - w / 2, top, cx + w / 2, top + h)
                if any(a[0] < r[2] and r[0] < a[2] and a[1] < r[3] and r[1] < a[3]
                       for a in rects.values()):  # fmt: skip
                    continue
                if any(_segment_hits(*a, *b, *r) for a, b in lines):
                    continue
                crossed = 0
                for a, n in ((a, n) for a in srcs for n in inner if n != a):
                    crossed += _segment_hits(*placed[a], cx, cy, *inner[n])
                    if crossed >= least:
                        break
                if crossed < least:
                    spot, least = (cx, cy), crossed
                if crossed == 0:
                    break
            if least == 0:
                break
        if spot is None:
            top = max(lowest(end), column)
            spot = (right + _XSPACE + w / 2, top + h / 2)
            column = top + h + _YSPACE
        placed[end] = spot
    return {end: placed[end] for end in ends}


def _shrunk(r: tuple[float, float, float, float], mx: float, my: float) -> tuple[float, ...]:
    return (r[0] + mx, r[1] + my, r[2] - mx, r[3] - my)


def _free_corner(
    part: dict[str, tuple[float, float]],
    placed: dict[str, tuple[float, float]],
    box: dict[str, tuple[float, float]],
    edges: list[tuple[str, str]],
) -> tuple[float, float] | None:
    """Where a part of a level no transition connects (`part`, its top-left at 0, 0) fits
    inside the room the `placed` parts already take: the highest, then rightmost, offset at
    which its labels keep `_COMPONENT_GAP / 2` from every placed label (lit or not) and no
    placed arrow runs through it; None if there is no such room (it then goes to the right).
    The guard node and its abort state sit in a corner instead of widening the graph."""
    w = max(x + box[n][0] / 2 for n, (x, _) in part.items())
    h = max(y + box[n][1] / 2 for n, (_, y) in part.items())
    x0, y0, x1, y1 = _extent(placed, box)
    m = _COMPONENT_GAP / 2
    labels = [
        (cx - box[n][0] / 2 - m, cy - box[n][1] / 2 - m, cx + box[n][0] / 2 + m,
         cy + box[n][1] / 2 + m)
        for n, (cx, cy) in placed.items()
    ]  # fmt: skip
    lines = [(placed[s], placed[d]) for s, d in edges if s in placed and d in placed]
    tops = sorted({y0, *(r[3] - m + _YSPACE for r in labels)})
    for top in tops:
        if top + h > y1:
            break
        left = x1 - w
        while left >= x0:
            r = (left, top, left + w, top + h)
            free = not any(a[0] < r[2] and r[0] < a[2] and a[1] < r[3] and r[1] < a[3]
                           for a in labels)  # fmt: skip
            if free and not any(_segment_hits(*a, *b, *r) for a, b in lines):
                return left, top
            left -= 4.0
    return None


def _extent(
    pos: dict[str, tuple[float, float]], box: dict[str, tuple[float, float]]
) -> tuple[float, float, float, float]:
    """The box around the labels centred at `pos`: (x0, y0, x1, y1) [px]."""
    return (
        min(x - box[n][0] / 2 for n, (x, _) in pos.items()),
        min(y - box[n][1] / 2 for n, (_, y) in pos.items()),
        max(x + box[n][0] / 2 for n, (x, _) in pos.items()),
        max(y + box[n][1] / 2 for n, (_, y) in pos.items()),
    )


def _part_layout(
    part: graph_core,
    level: Level,
    box: dict[str, tuple[float, float]],
    edges: list[tuple[str, str]],
    ends: list[str],
) -> dict[str, tuple[float, float]]:
    """One connected part: grandalf's layers and orderings, then of the five horizontal
    placements it computes (four Brandes-Köpf alignments and their balanced mean) the one whose
    straight edges cross the fewest labels, then the narrowest. Rerun draws edges straight,
    not along the layout's bends, so a placement that runs the main path down one column and
    keeps long edges clear of labels reads best. A group's frame is not an obstacle: arrows
    cross frames. An exit is scored as a line straight down out of the level."""
    layout = SugiyamaLayout(part)
    layout.xspace, layout.yspace = _XSPACE, _YSPACE
    # grandalf gives the bends of a long edge (dummy vertices) the median label's width; Rerun
    # draws edges straight, so a bend needs no room: with -xspace it takes none (sorting_conveyor
    # 1172 -> 863 px wide; the gaps between labels are unchanged)
    layout.dw = -_XSPACE
    roots = [v for v in part.sV if v.data == level.initial]
    if not roots:
        roots = [v for v in part.sV if not v.e_in()] or [part.sV[0]]
    layout.init_all(roots=roots, inverted_edges=feedback_edges(part, roots))
    layout.draw(3)
    vs = list(part.sV)
    ys = {v.data: v.view.xy[1] for v in vs}
    placements = [{v.data: (v.view.xy[0], ys[v.data]) for v in vs}]
    placements += [{v.data: (layout.grx[v].x[k], ys[v.data]) for v in vs} for k in range(4)]
    names = [*placements[0], *ends]
    mine = [(s, d) for s, d in edges if s in names and d in names]
    exits = [n for n in level.exits if n in names]
    groups = set(level.nested)
    below = max(y for _, y in placements[0].values()) + 1e4

    def segments(pos: dict[str, tuple[float, float]], node: str | None = None) -> list[_Segment]:
        out: list[_Segment] = [(pos[s], pos[d], (s, d)) for s, d in mine]
        out += [(pos[n], (pos[n][0], below), (n,)) for n in exits]
        return out if node is None else [seg for seg in out if node in seg[2]]

    def score(pos: dict[str, tuple[float, float]]) -> tuple[int, float]:
        x0, _, x1, _ = _extent(pos, box)
        return _crossings(pos, box, segments(pos), groups), x1 - x0

    def touching(pos: dict[str, tuple[float, float]], node: str) -> int:
        """The crossings `node` takes part in: its edges through labels, edges through it."""
        n = _crossings(pos, box, segments(pos, node), groups)
        if node not in groups:
            (cx, cy), (w, h) = pos[node], box[node]
            rect = (cx - w / 2, cy - h / 2, cx + w / 2, cy + h / 2)
            n += sum(
                _segment_hits(*a, *b, *rect) for a, b, ends in segments(pos) if node not in ends
            )
        return n

    if ends:
        placements = [p | _end_column(ends, p, box, edges, groups) for p in placements]
    return _narrowed(min(placements, key=score), box, touching)


def _narrowed(
    pos: dict[str, tuple[float, float]],
    box: dict[str, tuple[float, float]],
    touching: Callable[[dict[str, tuple[float, float]], str], int],
) -> dict[str, tuple[float, float]]:
    """`pos` with the states that stick out at the left or right moved in, one at a time, to
    the nearest spot within the others' width where its label keeps the layer gap from every
    label and it takes part in no more crossings of edges and labels (`touching`): a
    Brandes-Köpf alignment can leave a state alone at one side (sorting 797 -> 713 px wide)."""
    pos = dict(pos)
    for _ in range(len(pos)):
        x0, _, x1, _ = _extent(pos, box)
        out = sorted(n for n in pos if abs(pos[n][0] - box[n][0] / 2 - x0) < 1e-6
                     or abs(pos[n][0] + box[n][0] / 2 - x1) < 1e-6)  # fmt: skip
        moved = False
        for node in out:
            others = {n: p for n, p in pos.items() if n != node}
            ox0, _, ox1, _ = _extent(others, box)
            (cx, cy), (w, h) = pos[node], box[node]
            if ox1 - ox0 >= x1 - x0 - 1.0:
                continue
            crossed = touching(pos, node)
            steps = int((ox1 - ox0 - w) / 4.0) + 1
            spots = sorted((ox0 + w / 2 + 4.0 * i for i in range(max(steps, 0))),
                           key=lambda x: (abs(x - cx), x))  # fmt: skip
            for x in spots:
                if any(abs(x - px) < (w + box[n][0]) / 2 + _XSPACE
                       and abs(cy - py) < (h + box[n][1]) / 2 + _YSPACE / 2
                       for n, (px, py) in others.items()):  # fmt: skip
                    continue
                trial = others | {node: (x, cy)}
                if touching(trial, node) <= crossed:
                    pos, moved = trial, True
                    break
            if moved:
                break
        if not moved:
            return pos
    return pos


def _crossings(
    pos: dict[str, tuple[float, float]],
    box: dict[str, tuple[float, float]],
    segments: list[_Segment],
    groups: set[str],
) -> int:
    """How many (segment, label) pairs overlap: a straight line through a label it does not
    join (each segment names the nodes it joins). Only the labels within a segment's height
    are looked at (the labels sorted by their tops): a long chain is not a square's work."""
    rects = sorted(
        (cy - h / 2, cy + h / 2, cx - w / 2, cx + w / 2, node)
        for node, (cx, cy) in pos.items()
        if node not in groups
        for w, h in [box[node]]
    )
    tops = [r[0] for r in rects]
    tallest = max((r[1] - r[0] for r in rects), default=0.0)
    n = 0
    for (ax, ay), (bx, by), ends in segments:
        lo = bisect.bisect_left(tops, min(ay, by) - tallest)
        hi = bisect.bisect_right(tops, max(ay, by))
        for y0, y1, x0, x1, node in rects[lo:hi]:
            if node not in ends and _segment_hits(ax, ay, bx, by, x0, y0, x1, y1):
                n += 1
    return n


def _segment_hits(
    ax: float, ay: float, bx: float, by: float, x0: float, y0: float, x1: float, y1: float
) -> bool:
    """Whether the segment a-b passes through the rectangle (Liang-Barsky clipping)."""
    t0, t1 = 0.0, 1.0
    dx, dy = bx - ax, by - ay
    for p, q in ((-dx, ax - x0), (dx, x1 - ax), (-dy, ay - y0), (dy, y1 - ay)):
        if p == 0:
            if q < 0:
                return False
            continue
        t = q / p
        if p < 0:
            t0 = max(t0, t)
        else:
            t1 = min(t1, t)
        if t0 > t1:
            return False
    return True
