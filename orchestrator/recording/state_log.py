"""The state machine over time: StateChange lanes and the graph with its active states lit."""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np
import rerun as rr
from rerun.chunk import Chunk

from .batches import StaticBatch
from .graph_drawing import GraphDrawing
from .machine_graph import MachineGraph
from .paths import ACTIVE_STATE, level_path
from .timeline import time_columns

__all__ = ["StateLog"]


def _rgba(colors: Iterable[int]) -> np.ndarray:
    """0xRRGGBBAA integers as the unambiguous uint32 array Rerun expects."""
    return np.fromiter(colors, dtype=np.uint32)


class StateLog:
    """Buffers state entries and turns them into StateChange and GraphNodes chunks.

    Three views of the same sequence:

    * `state_machine/active`: the leaf state by dotted path, one row per transition; its values
      are exactly the `to` fields of the run's `transitions` (after the initial state).
    * `state_machine/levels/<depth>`: one lane per nesting depth (`depth_0`, `depth_1`, ...): the
      state at that depth of the active leaf, so a nested machine's states sit under the state
      that runs it; a lane is empty (a gap) while the leaf is shallower.
    * `state_machine/graph`: the machine's graph (`GraphDrawing`), the active leaf and its
      ancestors lit.

    Args:
        graph: The machine tree's graph.
    """

    def __init__(self, graph: MachineGraph) -> None:
        self.graph = graph
        self._active: list[tuple[int, float, str]] = []
        self._lanes: dict[int, list[tuple[int, float, str]]] = {}
        self._lane_now: dict[int, str] = {}
        self._leaf: str | None = None
        self.drawing = GraphDrawing(graph)

    def log_static(self, static: StaticBatch) -> None:
        """State colours per lane, and what the graph keeps all along."""
        states = list(self.graph.states.values())
        static.log(
            ACTIVE_STATE,
            rr.StateConfiguration(
                values=[s.path for s in states], colors=_rgba(s.color for s in states)
            ),
        )
        depths: dict[int, dict[str, int]] = {}
        for s in states:
            depths.setdefault(s.path.count("."), {}).setdefault(s.name, s.color)
        for depth, colours in sorted(depths.items()):
            static.log(
                level_path(depth),
                rr.StateConfiguration(values=list(colours), colors=_rgba(colours.values())),
            )
        self.drawing.log_static(static)

    def enter(self, tick: int, t_s: float, leaf: str) -> None:
        """The machine entered leaf state `leaf` at control tick `tick`, time `t_s` [s]."""
        self._active.append((tick, t_s, leaf))
        names = leaf.split(".")
        for depth in range(max(len(names), len(self._lane_now))):
            name = names[depth] if depth < len(names) else ""
            if self._lane_now.get(depth, "") != name:
                self._lane(tick, t_s, depth, name)
        self._leaf = leaf

    def _lane(self, tick: int, t_s: float, depth: int, value: str) -> None:
        self._lanes.setdefault(depth, []).append((tick, t_s, value))
        self._lane_now[depth] = value

    def chunks(self) -> list[Chunk]:
        """The buffered entries as chunks; the buffer is emptied."""
        out = []
        if self._active:
            out.append(self._states(ACTIVE_STATE, self._active))
            out += self.drawing.chunks(*zip(*self._active, strict=True))
            self._active = []
        for depth, rows in self._lanes.items():
            if rows:
                out.append(self._states(level_path(depth), rows))
        self._lanes = {}
        return out

    @staticmethod
    def _states(entity: str, rows: list[tuple[int, float, str]]) -> Chunk:
        ticks, t_s, values = zip(*rows, strict=True)
        return Chunk.from_columns(
            entity,
            indexes=time_columns(np.array(ticks), np.array(t_s)),
            columns=rr.StateChange.columns(state=list(values)),
        )
