"""The machine tree as a graph: state paths, kinds, colours, regions, edges and expansions.

Pure data computed from a `MachineNode` (no Rerun, no simulator), once per machine: the
recorder turns it into StateConfiguration, GraphNodes and GraphEdges. What the graph shows
while a leaf runs is an expansion (`graph_views.py`): the nested machines holding the leaf
open, the others one node; each expansion is laid out once, top to bottom in flow order,
nested machines inside their owner's frame, by Graphviz's `dot` (`graph_dot.py`), or without
it by the built-in layered layout (`graph_layout.py`).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import TYPE_CHECKING

from ..language.machine import SAFE_STOP, guard_entries
from .graph_dot import dot_available
from .graph_layout import GraphLayout, Level
from .graph_views import LIT_MARK, ExpansionView, expansion_view, shifted
from .paths import frame_path

if TYPE_CHECKING:
    from ..language.loading import MachineNode

__all__ = [
    "GUARD",
    "GUARD_LABEL",
    "KIND_COLORS",
    "LIT_MARK",
    "PALETTE",
    "MachineGraph",
    "StateInfo",
    "build_graph",
    "on_path",
]

PALETTE: tuple[int, ...] = (
    0x4E79A7FF,  # blue
    0x9C755FFF,  # brown
    0x76B7B2FF,  # teal
    0xB07AA1FF,  # purple
    0xEDC948FF,  # yellow
    0x86BCB6FF,  # light teal
    0xBAB0ACFF,  # grey
    0xFF9DA7FF,  # pink
    0x1F77B4FF,  # dark blue
    0x8C564BFF,  # dark brown
)
"""Colours of running states, in order of appearance (RGBA, 0xRRGGBBAA). No reds or greens:
those mean success, failure and abort."""

KIND_COLORS: dict[str, int] = {
    "success": 0x2E9E44FF,  # a final state with the machine's success outcome
    "final": 0xE8A317FF,  # any other final state (failed, lost, missed, ...)
    "abort": 0xD62728FF,  # the built-in safe stop or the machine's `on_abort` state
}

GUARD = ":guard"
"""Node id of the graph's "guard fires" node, whose edge leads to the abort state."""
GUARD_LABEL = "guard fires"


@dataclass(frozen=True)
class StateInfo:
    """One state of the tree.

    Attributes:
        path: Dotted path (`PICK.SEARCH`).
        name: Name within its machine level (`SEARCH`).
        region: Dotted path of the machine level it belongs to (`""` for the top level).
        kind: `state`, `composite` (runs a nested machine), `success`, `final` or `abort`.
        color: Display colour, 0xRRGGBBAA.
        final: The outcome a final state ends its machine with (None for other states).
    """

    path: str
    name: str
    region: str
    kind: str
    color: int
    final: str | None = None


def on_path(state: str, leaf: str) -> bool:
    """True if `state` is `leaf` or one of its ancestors (`PICK` is on `PICK.SEARCH`)."""
    return leaf == state or leaf.startswith(state + ".")


@dataclass(frozen=True)
class MachineGraph:
    """The states, regions and edges of a machine tree, with its layout.

    Attributes:
        states: Dotted path -> state, in declaration order (depth first).
        regions: Region path -> the state that owns it (`""` -> `""` for the top level).
        edges: The arrows a reader follows, (source, target) node ids: transitions (out of
            a nested machine from the final states its outcomes come from, into it to the state
            that runs it), entry from that state to the nested initial state, and `GUARD` to
            the abort state.
        views: What the graph shows while a leaf runs: the expansion with the leaf's nested
            machines open (`view`), keyed by the open composite states (sorted).
        initial_leaf: The leaf state the machine starts in.
        outcomes: Each edge -> the outcomes that take it (empty for entries and the guard's).
    """

    states: dict[str, StateInfo]
    regions: dict[str, str]
    edges: list[tuple[str, str]]
    views: dict[tuple[str, ...], ExpansionView]
    initial_leaf: str
    outcomes: dict[tuple[str, str], list[str]]

    def view(self, leaf: str) -> ExpansionView:
        """The expansion shown while `leaf` runs: the nested machines holding it open."""
        return self.views[self.expansion(leaf)]

    def expansion(self, leaf: str) -> tuple[str, ...]:
        """The composite states that hold `leaf` (its open nested machines), sorted."""
        parts = leaf.split(".")
        owners = (".".join(parts[:i]) for i in range(1, len(parts)))
        composites = set(self.regions.values())
        return tuple(sorted(o for o in owners if o and o in composites))

    @property
    def layout(self) -> GraphLayout:
        """The layout of the initial leaf's expansion."""
        return self.view(self.initial_leaf).layout

    @property
    def positions(self) -> dict[str, tuple[float, float]]:
        """Node id -> centre (x, y) in the initial expansion [px]; y grows downwards."""
        return self.layout.positions

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        """A box holding every expansion, each laid out from (0, 0): (x0, y0, x1, y1) [px]."""
        boxes = [v.layout.bounds for v in self.views.values()]
        return (
            min(b[0] for b in boxes),
            min(b[1] for b in boxes),
            max(b[2] for b in boxes),
            max(b[3] for b in boxes),
        )

    def lanes(self, leaf: str) -> dict[str, str]:
        """The state of every machine level along `leaf`: region path -> state name.

        `PICK.SEARCH` gives `{"": "PICK", "PICK": "SEARCH"}`.
        """
        parts = leaf.split(".")
        out: dict[str, str] = {}
        for i, name in enumerate(parts):
            region = ".".join(parts[:i])
            if region in self.regions:
                out[region] = name
        return out

    def region_states(self, region: str) -> list[StateInfo]:
        """The states of one machine level, in declaration order."""
        return [s for s in self.states.values() if s.region == region]


def _region_of(path: str) -> str:
    return path.rsplit(".", 1)[0] if "." in path else ""


def build_graph(root: MachineNode, use_dot: bool | None = None) -> MachineGraph:
    """Walk the machine tree once and derive everything the recording shows of it.

    Args:
        root: The machine tree.
        use_dot: Lay the expansions out with Graphviz's `dot` (graph_dot.py); None: if it is
            installed, else with the built-in layout (graph_layout.py) and a warning.
    """
    walked = list(root.walk())
    paths = [p for p, _, _ in walked]
    abort = root.on_abort if root.on_abort is not None else SAFE_STOP
    states: dict[str, StateInfo] = {}
    regions: dict[str, str] = {"": ""}
    palette_i = 0
    for path, spec, node in walked:
        region = _region_of(path)
        name = path.rsplit(".", 1)[-1]
        if region and region not in regions:
            owner = region
            while owner and owner not in paths:
                owner = _region_of(owner)
            regions[region] = owner
        if on_path(abort, path):
            kind = "abort"
        elif spec.final is not None:
            success = "succeeded" if not region else (node.outcomes() or [""])[0]
            kind = "success" if spec.final == success else "final"
        elif name in node.children or name in getattr(node, "branches", {}):
            kind = "composite"
        else:
            kind = "state"
        if kind in KIND_COLORS:
            color = KIND_COLORS[kind]
        else:
            color = PALETTE[palette_i % len(PALETTE)]
            palette_i += 1
        states[path] = StateInfo(path, name, region, kind, color, spec.final)
    if abort not in states:
        states[abort] = StateInfo(abort, abort, "", "abort", KIND_COLORS["abort"])

    initials = {_region_of(path): node.initial for path, _, node in walked}
    flow: dict[str, list[tuple[str, str]]] = {region: [] for region in regions}
    outcomes: dict[tuple[str, str], list[str]] = {}

    def add(src: str, dst: str, outcome: str | None = None) -> None:
        if src == dst:
            return
        outs = outcomes.setdefault((src, dst), [])
        if outcome is not None and outcome not in outs:
            outs.append(outcome)

    retries: dict[str, int] = {}
    guards: dict[str, list[str]] = {}
    for path, spec, _node in walked:
        region = _region_of(path)
        prefix = region + "." if region else ""
        for outcome, target in spec.transitions.items():
            flow[region].append((path, prefix + target))
            for src in _exits(path, outcome, states, regions) or [path]:
                add(src, prefix + target, outcome)
        if getattr(spec, "retry", 0):
            retries[path] = int(spec.retry)
        if getattr(spec, "guards", None):
            guards[path] = [name for _, name, _ in guard_entries(spec.guards)]
    for region, owner in regions.items():
        if region:
            add(owner, f"{region}.{initials[region]}")
    add(GUARD, abort)

    leaf, node = root.initial, root
    while leaf.rsplit(".", 1)[-1] in node.children:
        node = node.children[leaf.rsplit(".", 1)[-1]]
        leaf = f"{leaf}.{node.initial}"
    names = {path: info.name for path, info in states.items()} | {GUARD: GUARD_LABEL}
    captions = {o: "/" + frame_path(o) for o in set(regions.values()) if o}
    composites = {owner for owner in regions.values() if owner}
    top = _level("", states, regions, flow, initials, abort)
    keys = {
        tuple(sorted(o for o in composites if on_path(o, path) and o != path)) for path in states
    }
    if use_dot is None and not dot_available():
        use_dot = False
        warnings.warn(
            "Graphviz's `dot` is not on the PATH: the machine graph is laid out by the built-in"
            " layout (install graphviz for dot's)",
            RuntimeWarning,
            stacklevel=2,
        )
    views = {
        key: expansion_view(
            top, names, composites, outcomes, retries, guards, captions, key, use_dot is not False
        )
        for key in sorted(keys)
    }
    # every expansion top-aligned at y = 0 and centred on the widest: switching between them
    # keeps the graph in place in its panel
    width = max(v.layout.bounds[2] - v.layout.bounds[0] for v in views.values())
    for key, v in views.items():
        x0, y0, x1, _ = v.layout.bounds
        views[key] = shifted(v, (width - (x1 - x0)) / 2 - x0, -y0)
    return MachineGraph(states, regions, list(outcomes), views, leaf, outcomes)


def _exits(
    path: str, outcome: str, states: dict[str, StateInfo], regions: dict[str, str]
) -> list[str]:
    """The final states of the machine nested in `path` that end it with `outcome`."""
    if regions.get(path) != path:
        return []  # a skill state, or a parallel state (its outcome is its rule's)
    return [s.path for s in states.values() if s.region == path and s.final == outcome]


def _level(
    region: str,
    states: dict[str, StateInfo],
    regions: dict[str, str],
    flow: dict[str, list[tuple[str, str]]],
    initials: dict[str, str],
    abort: str,
) -> Level:
    """The layout input of one machine level and, recursively, of the levels nested in it."""
    prefix = region + "." if region else ""
    nodes = [s.path for s in states.values() if s.region == region]
    level = Level(nodes, list(flow.get(region, [])), prefix + initials.get(region, ""))
    if region:
        level.exits = [n for n in nodes if states[n].final is not None]
    for node in nodes:
        owned = [r for r, owner in regions.items() if r and owner == node]
        if owned:
            level.nested[node] = [_level(r, states, regions, flow, initials, abort) for r in owned]
    if not region:
        level.nodes.append(GUARD)
        level.edges.append((GUARD, abort))
    return level
