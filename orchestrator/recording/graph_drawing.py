"""The machine graph as Rerun draws it: labels, arrows, frames of nested machines, lit states.

Rerun's graph view draws a labelled node as its text in a frame, the text in the node's colour
(the frame's fill follows the viewer's light or dark theme), and an edge as a straight arrow
between frames. So that every label reads on either theme, idle states are a mid grey and
final states their kind's colour (green, amber, red); the active leaf and the states running
it are lit: an accent colour (finals keep theirs) and `LIT_MARK` before the name.

A view showing more than one graph entity outlines each with a rectangle captioned with its
entity path. The frames of nested machines are exactly that: one entity per nested machine
(`state_machine/graph/PICK/GRASP`) holding two invisible corner points, so that its outline is
the machine's frame and its caption names the nesting. Everything a reader follows (states,
arrows) is one entity, `state_machine/graph`: Rerun draws edges only within an entity.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

import numpy as np
import rerun as rr
from rerun.chunk import Chunk

from .batches import StaticBatch
from .machine_graph import GUARD, GUARD_LABEL, LIT_MARK, MachineGraph, on_path
from .paths import GRAPH, frame_path
from .timeline import time_columns

__all__ = ["ACCENT", "IDLE", "GraphDrawing"]

IDLE = 0x8C8C8CFF
"""Text colour of a state that is not active: legible on the light and the dark theme."""
ACCENT = 0x2F80EDFF
"""Text colour of the active leaf and the states running it (final states keep theirs)."""
_ENTITY_PAD = 10.0
"""Rerun outlines an entity 10 px outside its nodes [px]."""
_CORNER_R = 0.5
"""Radius of a frame's (transparent) corner points [px]."""


def _rgba(colors: Iterable[int]) -> np.ndarray:
    """0xRRGGBBAA integers as the unambiguous uint32 array Rerun expects."""
    return np.fromiter(colors, dtype=np.uint32)


class GraphDrawing:
    """The static graph and, per state entry, which nodes are lit.

    Args:
        graph: The machine tree's graph (with its layout).
    """

    def __init__(self, graph: MachineGraph) -> None:
        self.graph = graph
        self.node_ids = [*graph.states, GUARD]
        infos = list(graph.states.values())
        self.labels = [s.name for s in infos] + [GUARD_LABEL]
        self._lit_labels = [LIT_MARK + s.name for s in infos] + [GUARD_LABEL]
        final = ("success", "final", "abort")
        self._idle = _rgba([s.color if s.kind in final else IDLE for s in infos] + [IDLE])
        self._lit = _rgba([s.color if s.kind in final else ACCENT for s in infos] + [IDLE])

    def log_static(self, static: StaticBatch) -> None:
        """Nodes (ids, positions), arrows, and the nested frames. Labels and colours change
        over time (`chunks`): static values would hide the temporal ones."""
        static.log(
            GRAPH,
            rr.GraphNodes(
                node_ids=self.node_ids,
                positions=[self.graph.positions[n] for n in self.node_ids],
                show_labels=True,
            ),
            rr.GraphEdges(edges=self.graph.edges, graph_type="directed"),
        )
        inset = _ENTITY_PAD + _CORNER_R
        for owner, (x0, y0, x1, y1) in self.graph.layout.groups.items():
            static.log(
                frame_path(owner),
                rr.GraphNodes(
                    node_ids=["top_left", "bottom_right"],
                    positions=[(x0 + inset, y0 + inset), (x1 - inset, y1 - inset)],
                    colors=_rgba([0, 0]),
                    radii=[_CORNER_R, _CORNER_R],
                    show_labels=False,
                ),
            )

    def chunks(
        self, ticks: Sequence[int], t_s: Sequence[float], leaves: Sequence[str]
    ) -> list[Chunk]:
        """Labels and colours of every node at each state entry (control tick, time [s],
        the leaf entered): the leaf and its ancestors lit."""
        lit = np.array(
            [[on_path(node, leaf) for node in self.node_ids] for leaf in leaves], dtype=bool
        )
        labels = [
            lit_label if on else label
            for row in lit
            for on, label, lit_label in zip(row, self.labels, self._lit_labels, strict=True)
        ]
        colors = np.where(lit, self._lit, self._idle).ravel()
        n = len(self.node_ids)
        return [
            Chunk.from_columns(
                GRAPH,
                indexes=time_columns(np.asarray(ticks), np.asarray(t_s)),
                columns=rr.GraphNodes.columns(labels=labels, colors=colors).partition(
                    [n] * len(leaves)
                ),
            )
        ]
