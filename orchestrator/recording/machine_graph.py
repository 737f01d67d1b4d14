"""The machine tree as a graph: state paths, kinds, colours, regions, edges and a layout.

Pure data computed from a `MachineNode` (no Rerun, no simulator): the recorder turns it into
StateConfiguration, GraphNodes and GraphEdges, and uses `lanes` to split a leaf path into the
state of every machine level it passes through.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

from ..language.machine import SAFE_STOP

if TYPE_CHECKING:
    from ..language.loading import MachineNode

__all__ = ["KIND_COLORS", "PALETTE", "MachineGraph", "StateInfo", "build_graph", "on_path"]

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

_DX, _DY = 150.0, 90.0
"""Graph layout spacing in the graph view's units."""


@dataclass(frozen=True)
class StateInfo:
    """One state of the tree.

    Attributes:
        path: Dotted path (`PICK.SEARCH`).
        name: Name within its machine level (`SEARCH`).
        region: Dotted path of the machine level it belongs to (`""` for the top level).
        kind: `state`, `composite` (runs a nested machine), `success`, `final` or `abort`.
        color: Display colour, 0xRRGGBBAA.
    """

    path: str
    name: str
    region: str
    kind: str
    color: int


def on_path(state: str, leaf: str) -> bool:
    """True if `state` is `leaf` or one of its ancestors (`PICK` is on `PICK.SEARCH`)."""
    return leaf == state or leaf.startswith(state + ".")


@dataclass(frozen=True)
class MachineGraph:
    """The states, regions and edges of a machine tree, with a deterministic layout.

    Attributes:
        states: Dotted path -> state, in declaration order (depth first).
        regions: Region path -> the state that owns it (`""` -> `""` for the top level).
        edges: Directed (source path, target path) pairs: transitions, entry into a nested
            machine's initial state, and abort from every top-level state.
        positions: Dotted path -> (x, y) in the graph view.
        initial_leaf: The leaf state the machine starts in.
    """

    states: dict[str, StateInfo]
    regions: dict[str, str]
    edges: list[tuple[str, str]]
    positions: dict[str, tuple[float, float]]
    initial_leaf: str

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


def build_graph(root: MachineNode) -> MachineGraph:
    """Walk the machine tree once and derive everything the recording shows of it."""
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
        states[path] = StateInfo(path, name, region, kind, color)
    if abort not in states:
        states[abort] = StateInfo(abort, abort, "", "abort", KIND_COLORS["abort"])

    edges: list[tuple[str, str]] = []

    def add(src: str, dst: str) -> None:
        if src != dst and src in states and dst in states and (src, dst) not in edges:
            edges.append((src, dst))

    for path, spec, node in walked:
        region = _region_of(path)
        prefix = region + "." if region else ""
        for target in spec.transitions.values():
            add(path, prefix + target)
        if region and path.rsplit(".", 1)[-1] == node.initial:
            add(regions[region], path)
    for info in list(states.values()):
        if info.region == "" and info.kind in ("state", "composite"):
            add(info.path, abort)

    leaf, node = root.initial, root
    while leaf.rsplit(".", 1)[-1] in node.children:
        node = node.children[leaf.rsplit(".", 1)[-1]]
        leaf = f"{leaf}.{node.initial}"
    return MachineGraph(states, regions, edges, _layout(root, abort), leaf)


def _layout(root: MachineNode, abort: str) -> dict[str, tuple[float, float]]:
    """Top level in a row, each nested level in a zig-zag column below (or a row beside) its
    owner, alternating with depth; the abort state above the middle of the top row."""
    pos: dict[str, tuple[float, float]] = {}

    def place(node: MachineNode, prefix: str, x0: float, y0: float, row: bool) -> None:
        for i, name in enumerate(node.states):
            if row:
                x, y = x0 + i * _DX, y0
            else:
                x, y = x0 + (i % 2) * _DX * 0.5, y0 + (i + 1) * _DY
            pos[prefix + name] = (x, y)
            nested = [(f"{prefix}{name}.", node.children[name])] if name in node.children else []
            for bname, branch in getattr(node, "branches", {}).get(name, {}).items():
                if hasattr(branch, "states"):
                    nested.append((f"{prefix}{name}.{bname}.", branch))
            for k, (sub_prefix, sub) in enumerate(nested):
                if row:
                    place(sub, sub_prefix, x + k * _DX, y, row=False)
                else:
                    place(sub, sub_prefix, x + _DX, y + k * _DY, row=True)

    place(root, "", 0.0, 0.0, row=True)
    if abort not in pos:
        top = [p for p in pos if "." not in p]
        pos[abort] = ((len(top) - 1) * _DX / 2.0, -_DY * 1.5)
    return pos
