"""The machine graph laid out by Graphviz's `dot`: node, cluster and edge-label positions.

`dot` is run once per expansion of a machine (graph_views.py), when the recording prepares
its static scene, never while the physics steps. Every node is a fixed-size box the size of
its label as Rerun draws it lit (`LIT_MARK` before the name: a state lights up without
growing into a neighbour); every edge label and every frame's caption is a fixed-size HTML
table, so `dot` keeps exactly the room Rerun's text takes free of nodes and of each other.
An open nested machine is a cluster holding the state that runs it (its title) and its
states; each parallel branch is a cluster inside it. `dot -Tjson` gives the positions in
points with y up: one point is one pixel of Rerun's graph view at zoom 1, y flipped.

The title of an open nested machine shares its rank with the machine's initial state (a rank
less per open machine: ~55 px of height). Each expansion is laid out twelve ways (one `dot`
run) and the one shown at the largest zoom in the 1280x720 graph panel (blueprint.py
`panel_zoom`) is kept:
* edge labels as `dot`'s labels (each edge then spans two ranks, a label's or an empty one),
  or as nodes on their edges in the innermost frame holding both ends (an edge without a
  label spans one rank: shorter, and the labels sit elsewhere);
* as is, or with the top level's main path (`_spine`) in one column (`group`): narrower
  where labels would push each next state aside, wider elsewhere;
* a nested machine's exits (`_EXITS`) at least a rank long, or free to stay on the rank of
  the final state they leave (the flow after the machine starts beside its last states, not
  below them), or not ranking at all (the flow after it ranked on its own, beside it).
The guard node and the abort state, joined to nothing else, are laid out apart and put in
room the rest leaves free (graph_apart.py).

Without `dot` on the PATH (or when it fails) `dot_layout` returns None and the caller falls
back to the layout of graph_layout.py.
"""

from __future__ import annotations

import functools
import itertools
import json
import shutil
import subprocess
from dataclasses import dataclass

from .blueprint import panel_zoom
from .graph_apart import PAIR_GAP, apart_pairs, caption_box, free_spot, without
from .graph_layout import CAPTION_H, GraphLayout, Level, label_size
from .graph_routes import bezier_points

__all__ = ["DotLayout", "dot_available", "dot_layout"]

_NODESEP_IN = 0.1
"""Least gap between neighbours in a rank [in] (7 px; 11 px made the widest bundled
expansions 3-5 % wider)."""
_RANKSEP_IN = 0.15
"""Least gap between ranks [in] with `dot`'s edge labels: `dot` halves it (6 px) and gives
each edge two ranks, the middle one its label's (or empty)."""
_LABEL_NODE_RANKSEP_IN = 0.1
"""Least gap between ranks [in] (7 px) with edge labels as nodes: the arrow between two
states with no label between them (a straight chain, a machine's exit) is this long."""
_CLUSTER_MARGIN = 6.0
"""Room inside a frame around its states [pt = px]."""
_OUTLINE_PAD = 10.0
"""Rerun outlines each graph entity this far outside its nodes, its path written above [px]."""
_LABEL_ROOM = 3.0
"""`dot` keeps each edge label's box this much larger on every side than Rerun draws it
[px]: `dot` runs an edge right along its label's box, and the other edges leaving the same
state as close; with the room, the drawn arrows (graph_routes.py) pass clear of it."""
_IN, _OUT = " #in", " #out"
"""The two halves of a labelled edge (source -> label node -> target), by their comments."""
_EXITS = ("below", "level", "loose")
"""How a nested machine's exit (an arrow from its final state out of its frame) is ranked:
at least a rank below the final state (`dot`'s default), on its rank or below (`minlen=0`),
or not at all (`constraint=false`)."""
_TIMEOUT_S = 30.0
"""A `dot` run taking longer is taken as failed (the bundled graphs take ~10 ms)."""
_MANY_WAYS_NODES = 150
"""Above this many boxes an expansion is laid out one way only: the ways are tried for a
graph that fits a panel readably (a bundled machine has 10-40); 24 ways of a 1,500-state
chain took 15 s of `dot` on a quiet host and ran past `_TIMEOUT_S` under load, falling back
to the built-in layout."""


@dataclass(frozen=True)
class DotLayout:
    """A `dot` layout in Rerun's graph-view units (x right, y down, 1 px per point).

    Attributes:
        layout: Node centres and label sizes, the frames of the open nested machines (below
            their captions) and the captions' widths.
        edge_labels: Edge (source, target) -> the centre of its label.
        splines: Edge (source, target) -> points along the spline `dot` routed it on, from
            its source to its target (graph_routes.py).
    """

    layout: GraphLayout
    edge_labels: dict[tuple[str, str], tuple[float, float]]
    splines: dict[tuple[str, str], list[tuple[float, float]]]


def dot_available() -> bool:
    """True if Graphviz's `dot` is on the PATH."""
    return shutil.which("dot") is not None


def _quote(text: str) -> str:
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'


def _box(w: float, h: float) -> str:
    """An HTML label that is an empty box of exactly w x h points."""
    return (
        f'<<TABLE BORDER="0" CELLBORDER="0" CELLSPACING="0" CELLPADDING="0" FIXEDSIZE="TRUE" '
        f'WIDTH="{max(1, round(w))}" HEIGHT="{max(1, round(h))}"><TR><TD></TD></TR></TABLE>>'
    )


def dot_source(
    top: Level,
    sizes: dict[str, tuple[float, float]],
    edges: dict[tuple[str, str], tuple[float, float] | None],
    captions: dict[str, tuple[float, float]],
    straight: bool = False,
    label_nodes: bool = True,
    exits: str = "below",
    ordered: bool = False,
) -> tuple[str, dict[str, str]]:
    """The DOT text of a machine tree and the dot id of each node.

    Args:
        top: The top level with the nested levels shown open.
        sizes: Node id -> the box it takes (w, h) [px].
        edges: The arrows drawn, (source, target) -> the size of its label (None: no label).
        captions: Open nested machine's owner -> its caption's size (w, h) [px].
        straight: Keep the top level's main path (`_spine`) in one column.
        label_nodes: Each edge label a node on its edge (else a label of `dot`'s).
        exits: How a nested machine's exits without a label are ranked (`_EXITS`).
        ordered: Keep each node's arrows in their order (`ordering=out`) where `dot` would
            reorder them to cross fewer.
    """
    ids: dict[str, str] = {}
    columns = _spines(top) if straight else {}
    chains = _cluster_chains(top)
    # each label node sits in the innermost frame holding both ends of its edge
    label_ids = {e: f"e{i}" for i, e in enumerate(e for e, t in edges.items() if t is not None)}
    if not label_nodes:
        label_ids = {}
    held: dict[int, list[tuple[str, str]]] = {}
    for src, dst in label_ids:
        a, b = chains[src], chains[dst]
        common = 0
        for x, y in zip(a, b, strict=False):
            if x != y:
                break
            common = x
        held.setdefault(common, []).append((src, dst))
    ranksep = _LABEL_NODE_RANKSEP_IN if label_nodes else _RANKSEP_IN
    lines = [
        "digraph machine {",
        f"  graph [rankdir=TB, nodesep={_NODESEP_IN}, ranksep={ranksep}, newrank=true, "
        f"{'ordering=out, ' if ordered else ''}"
        f"margin=0, pad=0, labeljust=l, labelloc=t, fontsize=12];",
        '  node [shape=box, fixedsize=true, label="", margin=0, penwidth=0];',
        "  edge [arrowhead=none, penwidth=1];",
    ]
    clusters = [0]

    def box_line(name: str, size: tuple[float, float], comment: str, group: int | None,
                 indent: str) -> None:  # fmt: skip
        w, h = size
        in_group = f", group=g{group}" if group is not None else ""
        lines.append(f"{indent}{name} [width={w / 72:.4f}, height={h / 72:.4f}, "
                     f"comment={_quote(comment)}{in_group}];")  # fmt: skip

    def node_line(node: str, indent: str) -> None:
        ids[node] = f"n{len(ids)}"
        box_line(ids[node], sizes[node], node, columns.get(node), indent)

    def labels_in(frame: int, indent: str) -> None:
        for src, dst in held.get(frame, []):
            same = columns.get(src) is not None and columns.get(src) == columns.get(dst)
            box_line(label_ids[(src, dst)], edges[(src, dst)], f"{src} -> {dst}",
                     columns[src] if same else None, indent)  # fmt: skip

    def cluster(name: str, label: tuple[float, float] | None, indent: str) -> int:
        clusters[0] += 1
        lines.append(f"{indent}subgraph cluster_{clusters[0]} {{")
        lines.append(f"{indent}  comment={_quote(name)}; margin={_CLUSTER_MARGIN};")
        text = _box(*label) if label else '""'
        lines.append(f"{indent}  label={text};")
        return clusters[0]

    def level(lv: Level, indent: str) -> None:
        for node in lv.nodes:
            if node not in lv.nested:
                node_line(node, indent)
                continue
            frame = cluster(node, captions.get(node), indent)
            node_line(node, indent + "  ")
            branches = lv.nested[node]
            for i, branch in enumerate(branches):
                if len(branches) > 1:
                    inner = cluster(f"{node}#{i}", None, indent + "  ")
                    level(branch, indent + "    ")
                    labels_in(inner, indent + "    ")
                    lines.append(f"{indent}  }}")
                else:
                    level(branch, indent + "  ")
                    # the title beside the initial state, not a rank above it
                    if branch.initial in ids:
                        lines.append(
                            f"{indent}  {{rank=same; {ids[node]}; {ids[branch.initial]};}}"
                        )
            labels_in(frame, indent + "  ")
            lines.append(f"{indent}}}")

    level(top, "  ")
    labels_in(0, "  ")
    for (src, dst), label in edges.items():
        name = src + " -> " + dst
        if label is None or not label_nodes:
            attrs = f", label={_box(*label)}" if label is not None else ""
            if label is None and exits != "below" and _leaves(chains[src], chains[dst]):
                attrs += ", minlen=0" if exits == "level" else ", constraint=false"
            lines.append(f"  {ids[src]} -> {ids[dst]} [comment={_quote(name)}{attrs}];")
            continue
        # the label is a node on its edge, where Rerun draws it (source -> label -> target)
        node = label_ids[(src, dst)]
        lines.append(f"  {ids[src]} -> {node} [comment={_quote(name + _IN)}];")
        lines.append(f"  {node} -> {ids[dst]} [comment={_quote(name + _OUT)}];")
        if src == dst:  # a retry's loop: its label beside the state
            lines.append(f"  {{rank=same; {ids[src]}; {node};}}")
    # a top-level state nothing leads to (the guard node) starts beside the initial state,
    # in the room the first layers leave, not in a column of its own
    targets = {dst for _, dst in edges}
    for node in top.nodes:
        if node != top.initial and node not in targets and top.initial in ids:
            lines.append(f"  {ids[top.initial]} -> {ids[node]} [style=invis, minlen=0];")
    lines.append("}")
    return "\n".join(lines) + "\n", ids


def _leaves(src: list[int], dst: list[int]) -> bool:
    """True if an arrow from a node in the frames `src` to one in `dst` leaves a frame for
    one holding it (a nested machine's exit)."""
    return len(src) > len(dst) and src[: len(dst)] == dst


def _cluster_chains(top: Level) -> dict[str, list[int]]:
    """Node -> the numbers of the frames holding it, outermost first, numbered as
    `dot_source` opens them (a nested machine's owner is in its own frame)."""
    out: dict[str, list[int]] = {}
    count = [0]

    def walk(lv: Level, chain: list[int]) -> None:
        for node in lv.nodes:
            if node not in lv.nested:
                out[node] = chain
                continue
            count[0] += 1
            frame = [*chain, count[0]]
            out[node] = frame
            branches = lv.nested[node]
            for branch in branches:
                if len(branches) > 1:
                    count[0] += 1
                    walk(branch, [*frame, count[0]])
                else:
                    walk(branch, frame)

    walk(top, [])
    return out


def _spine(lv: Level) -> list[str]:
    """A level's main path: the longest path from its initial state along its transitions
    (the transitions closing a loop left out) in states that lead on."""
    succ: dict[str, list[str]] = {n: [] for n in lv.nodes}
    for a, b in lv.edges:
        if a in succ and b in succ and a != b and b not in succ[a]:
            succ[a].append(b)
    if lv.initial not in succ:
        return []
    # a depth-first walk from the initial state, on an explicit stack (a user's machine may
    # chain thousands of states): the transitions that close a loop are left out, and the
    # states come out in post-order, each after every state it leads to
    dag: dict[str, list[str]] = {n: [] for n in lv.nodes}
    on_path: dict[str, bool] = {lv.initial: True}  # seen; True while on the walk's path
    post: list[str] = []
    stack = [(lv.initial, iter(succ[lv.initial]))]
    while stack:
        n, ahead = stack[-1]
        for m in ahead:
            if on_path.get(m):
                continue  # closes a loop
            dag[n].append(m)
            if m not in on_path:
                on_path[m] = True
                stack.append((m, iter(succ[m])))
                break
        else:
            on_path[n] = False
            post.append(n)
            stack.pop()
    # the longest way on, counted in states that go on (a path ending in a final state is no
    # longer for it); of equal ones, the first declared
    going: dict[str, int] = {}
    onward: dict[str, str | None] = {}
    for n in post:
        best, most = None, -1
        for m in dag[n]:
            if going[m] > most:
                best, most = m, going[m]
        onward[n] = best
        going[n] = (1 if succ[n] else 0) + max(most, 0)
    path: list[str] = []
    at: str | None = lv.initial
    while at is not None:
        path.append(at)
        at = onward[at]
    return path


def _spines(top: Level) -> dict[str, int]:
    """Node -> the number of its level's main path, for the top level's (the nested levels'
    straightened as well made the bundled graphs wider, never narrower)."""
    return dict.fromkeys(_spine(top), 0)


def run_dot(source: str) -> dict | None:
    """`dot -Tjson` of `source`, parsed (a fresh object each call); None if `dot` is missing
    or fails."""
    out = run_dots([source])
    return out[0] if out else None


def run_dots(sources: list[str]) -> list[dict] | None:
    """`dot -Tjson` of each of `sources` (one graph each), in one `dot` run, parsed (fresh
    objects each call); None if `dot` is missing or fails."""
    try:
        text = _dot_json("".join(sources))
        decoder, out, at = json.JSONDecoder(), [], 0
        while len(out) < len(sources):
            while at < len(text) and text[at].isspace():
                at += 1
            graph, at = decoder.raw_decode(text, at)
            out.append(graph)
        return out
    except (_DotFailed, json.JSONDecodeError):
        return None


class _DotFailed(Exception):
    """`dot` is missing, timed out or refused the source: not kept by the memo below, so a
    run that timed out on a loaded host is tried again next time."""


@functools.lru_cache(maxsize=256)
def _dot_json(source: str) -> str:
    """`dot -Tjson`'s output for `source`, kept per process: a layout depends on its source
    alone, and a batch's recordings (or a session's episodes) draw the same machines with
    the same lit states again (each `dot` run is a process start, ~30 ms)."""
    exe = shutil.which("dot")
    if exe is None:
        raise _DotFailed("dot is not on the PATH")
    try:
        done = subprocess.run(
            [exe, "-Tjson"], input=source, capture_output=True, text=True,
            timeout=_TIMEOUT_S, check=False,
        )  # fmt: skip
    except (OSError, subprocess.TimeoutExpired) as e:
        raise _DotFailed(str(e)) from e
    if done.returncode != 0:
        raise _DotFailed(done.stderr)
    return done.stdout


def _floats(text: str) -> list[float]:
    return [float(v) for v in text.split(",")]


def dot_layout(
    top: Level,
    labels: dict[str, str],
    lit_labels: dict[str, str],
    edges: dict[tuple[str, str], str | None],
    captions: dict[str, str],
) -> DotLayout | None:
    """Lay out a machine tree with `dot`.

    Args:
        top: The top level with the nested levels shown open.
        labels: Node id -> its label text (as drawn unlit).
        lit_labels: Node id -> its text lit (the box is the larger of the two).
        edges: The arrows drawn, (source, target) -> its label's text (None: none).
        captions: Open nested machine's owner -> the caption Rerun writes above its frame.

    Returns:
        The layout, or None if `dot` is missing or fails.
    """
    sizes = {n: label_size(t) for n, t in labels.items()}
    boxes = {
        n: (max(w, label_size(lit_labels.get(n, labels[n]))[0]), h) for n, (w, h) in sizes.items()
    }
    label_boxes = {
        e: (label_size(t)[0] + 2 * _LABEL_ROOM, label_size(t)[1])
        if t is not None else None
        for e, t in edges.items()
    }  # fmt: skip
    caption_boxes = {o: (label_size(t)[0], CAPTION_H) for o, t in captions.items()}
    pairs = apart_pairs(top, edges)
    apart = {n for pair in pairs for n in pair}
    rest = without(top, apart)
    rest_edges = {e: t for e, t in edges.items() if not apart & set(e)}
    rest_boxes = {e: label_boxes[e] for e in rest_edges}
    variants = list(itertools.product((False, True), (False, True), _EXITS, (False, True)))
    if len(labels) > _MANY_WAYS_NODES:  # too large to read at any zoom: one way, not 24
        variants = variants[:1]
    made = [
        dot_source(rest, boxes, rest_boxes, caption_boxes, straight, label_nodes, exits, ordered)
        for label_nodes, straight, exits, ordered in variants
    ]
    outs = run_dots([source for source, _ in made])
    if outs is None:
        return None
    chains = _cluster_chains(rest)
    exiting = [e for e, t in rest_edges.items() if t is None and _leaves(*map(chains.get, e))]

    def score(laid: DotLayout) -> tuple[int, float, float]:
        """The fewest exits upwards (a loose exit may rank the flow after a machine above it:
        read backwards), the largest zoom; of equal ones (shown at 1), the smallest drawing."""
        x0, y0, x1, y1 = laid.layout.bounds
        pos = laid.layout.positions
        upward = sum(pos[b][1] < pos[a][1] for a, b in exiting)
        return -upward, panel_zoom((x0, y0, x1, y1)), -(x1 - x0) * (y1 - y0)

    # the pairs put aside only shrink a layout's zoom and grow its drawing: the layouts are
    # tried best first without them, until none left can beat the best with them
    read = [
        (score(_read(out, ids, rest_edges, captions, sizes, caption_boxes, False)), i)
        for i, ((_, ids), out) in enumerate(zip(made, outs, strict=True))
    ]
    best: tuple[tuple[int, float, float], DotLayout] | None = None
    for bound, i in sorted(read, key=lambda r: (r[0], -r[1]), reverse=True):
        if best is not None and best[0] >= bound:
            break
        laid = _read(outs[i], made[i][1], rest_edges, captions, sizes, caption_boxes)
        _put_apart(laid, pairs, sizes, boxes, label_boxes)
        _clear_the_outline_caption(top, laid.layout.positions, boxes, laid.layout.groups)
        if best is None or score(laid) > best[0]:
            best = (score(laid), laid)
    return best[1]


def _read(
    out: dict,
    ids: dict[str, str],
    edges: dict[tuple[str, str], str | None],
    captions: dict[str, str],
    sizes: dict[str, tuple[float, float]],
    caption_boxes: dict[str, tuple[float, float]],
    routed: bool = True,
) -> DotLayout:
    """The layout in `dot`'s output `out` of a source whose node ids are `ids` (the edges'
    splines only if `routed`)."""
    height = _floats(out["bb"])[3]

    def flip(x: float, y: float) -> tuple[float, float]:
        return x, height - y

    by_id = {n: i for i, n in enumerate(ids.values())}
    names = list(ids)
    positions: dict[str, tuple[float, float]] = {}
    groups: dict[str, tuple[float, float, float, float]] = {}
    for obj in out.get("objects", []):
        comment = obj.get("comment")
        if obj.get("name", "").startswith("cluster_"):
            if comment in captions:
                x0, y0, x1, y1 = _floats(obj["bb"])
                # the caption's band at the frame's top is where Rerun writes it, above
                # the frame's outline
                groups[comment] = (x0, height - y1 + CAPTION_H, x1, height - y0)
        elif obj.get("name") in by_id:
            positions[names[by_id[obj["name"]]]] = flip(*_floats(obj["pos"]))
    placed: dict[tuple[str, str], tuple[float, float]] = {}
    splines: dict[tuple[str, str], list[tuple[float, float]]] = {}
    for obj in out.get("objects", []):
        src, _, dst = obj.get("comment", "").partition(" -> ")
        if obj.get("name", "").startswith("e") and (src, dst) in edges:
            placed[(src, dst)] = flip(*_floats(obj["pos"]))
    halves: dict[tuple[str, str], dict[str, list[tuple[float, float]]]] = {}
    for edge in out.get("edges", []):
        comment = edge.get("comment", "")
        spot = edge.get("lp")
        if spot:
            placed[tuple(comment.partition(" -> ")[::2])] = flip(*_floats(spot))
        half = next((h for h in (_IN, _OUT) if comment.endswith(h)), "")
        src, _, dst = comment.removesuffix(half).partition(" -> ")
        if (src, dst) not in edges or not routed:
            continue
        # `pos`: the spline's points ("e,x,y" / "s,x,y" would be arrow ends: none are drawn)
        controls = [flip(*_floats(p)) for p in edge.get("pos", "").split() if p[:2] not in
                    ("e,", "s,")]  # fmt: skip
        if len(controls) >= 4:
            halves.setdefault((src, dst), {})[half] = bezier_points(controls)
    for key, parts in halves.items():
        if "" in parts:
            splines[key] = parts[""]
        elif _IN in parts and _OUT in parts:
            splines[key] = parts[_IN] + parts[_OUT]
    widths = {o: w for o, (w, _) in caption_boxes.items()}
    shown = {n: sizes[n] for n in positions}
    return DotLayout(GraphLayout(positions, groups, shown, widths), placed, splines)


def _put_apart(
    laid: DotLayout,
    pairs: list[tuple[str, str]],
    sizes: dict[str, tuple[float, float]],
    boxes: dict[str, tuple[float, float]],
    label_boxes: dict[tuple[str, str], tuple[float, float] | None],
) -> None:
    """Put each pair laid out apart (graph_apart.py) in room the layout leaves free, the
    first state above the second (`sizes`: as drawn unlit, `boxes`: the room taken lit)."""
    lay = laid.layout
    for a, b in pairs:
        taken = [_rect(lay.positions[n], boxes[n]) for n in lay.positions]
        taken += [_rect(at, label_boxes[e] or (0.0, 0.0)) for e, at in laid.edge_labels.items()]
        taken += [caption_box(f, lay.captions.get(o, 0.0)) for o, f in lay.groups.items()]
        lines = list(laid.splines.values())
        for src, dst in label_boxes:
            if src in lay.positions and dst in lay.positions:
                via = [laid.edge_labels[(src, dst)]] if (src, dst) in laid.edge_labels else []
                lines.append([lay.positions[src], *via, lay.positions[dst]])
        (wa, ha), (wb, hb) = boxes[a], boxes[b]
        x, y = free_spot((boxes[a], boxes[b]), taken, lines, panel_zoom, bool(lay.groups))
        w = max(wa, wb)
        lay.positions[a] = (x + w / 2, y + ha / 2)
        lay.positions[b] = (x + w / 2, y + ha + PAIR_GAP + hb / 2)
        lay.sizes[a], lay.sizes[b] = sizes[a], sizes[b]


def _rect(center: tuple[float, float], size: tuple[float, float]) -> tuple[float, ...]:
    (x, y), (w, h) = center, size
    return (x - w / 2, y - h / 2, x + w / 2, y + h / 2)


def _clear_the_outline_caption(
    top: Level,
    positions: dict[str, tuple[float, float]],
    boxes: dict[str, tuple[float, float]],
    groups: dict[str, tuple[float, float, float, float]],
) -> None:
    """Rerun outlines the whole graph `_OUTLINE_PAD` outside its topmost node and writes the
    graph's path above that, where the caption of a frame at the top would be too: the
    topmost top-level state outside every frame (the guard node) moves up until the outline
    runs above every frame's caption, if nothing is in its way."""
    if not groups:
        return
    limit = min(y0 - CAPTION_H for _, y0, _, _ in groups.values()) + _OUTLINE_PAD
    free = [n for n in top.nodes if n not in top.nested and n in positions]
    if not free:
        return
    node = min(free, key=lambda n: (positions[n][1] - boxes[n][1] / 2, top.nodes.index(n)))
    (x, y), (w, h) = positions[node], boxes[node]
    if y - h / 2 <= limit:
        return
    moved = (x - w / 2, limit, x + w / 2, y + h / 2)  # the box and the way up to it
    others = [
        (px - bw / 2, py - bh / 2, px + bw / 2, py + bh / 2)
        for n, (px, py) in positions.items()
        if n != node
        for bw, bh in [boxes[n]]
    ]
    others += [(x0, y0 - CAPTION_H, x1, y1) for x0, y0, x1, y1 in groups.values()]
    if not any(a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3]
               for a in [moved] for b in others):  # fmt: skip
        positions[node] = (x, limit + h / 2)
