"""The state machine over time: StateChange lanes and the graph with its active states lit."""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np
import rerun as rr
from rerun.chunk import Chunk

from .batches import StaticBatch
from .graph_drawing import GraphDrawing
from .machine_graph import MachineGraph, on_path
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
    * `state_machine/levels/<region>`: one lane per machine level (`root`, `PICK`, ...), so a
      nested machine's states sit under the state that runs it; a lane is reset (a gap) when
      its owning state is left.
    * `state_machine/graph`: the machine's graph (`GraphDrawing`), the active leaf and its
      ancestors lit.

    Args:
        graph: The machine tree's graph.
    """

    def __init__(self, graph: MachineGraph) -> None:
        self.graph = graph
        self._active: list[tuple[int, float, str]] = []
        self._lanes: dict[str, list[tuple[int, float, str]]] = {}
        self._lane_now: dict[str, str] = {}
        self._leaf: str | None = None
        self.drawing = GraphDrawing(graph)

    def log_static(self, static: StaticBatch) -> None:
        """State colours per lane, graph nodes (ids, labels, positions) and edges."""
        states = list(self.graph.states.values())
        static.log(
            ACTIVE_STATE,
            rr.StateConfiguration(
                values=[s.path for s in states], colors=_rgba(s.color for s in states)
            ),
        )
        for region in self.graph.regions:
            lane = self.graph.region_states(region)
            static.log(
                level_path(region),
                rr.StateConfiguration(
                    values=[s.name for s in lane], colors=_rgba(s.color for s in lane)
                ),
            )
        self.drawing.log_static(static)

    def enter(self, tick: int, t_s: float, leaf: str) -> None:
        """The machine entered leaf state `leaf` at control tick `tick`, time `t_s` [s]."""
        prev = self._leaf
        self._active.append((tick, t_s, leaf))
        lanes = self.graph.lanes(leaf)
        for region, now in list(self._lane_now.items()):
            owner = self.graph.regions[region]
            if region in lanes or not now:
                continue
            if prev is None or (on_path(owner, prev) and not on_path(owner, leaf)):
                self._lane(tick, t_s, region, "")
        for region, name in lanes.items():
            if self._lane_now.get(region) != name:
                self._lane(tick, t_s, region, name)
        self._leaf = leaf

    def _lane(self, tick: int, t_s: float, region: str, value: str) -> None:
        self._lanes.setdefault(region, []).append((tick, t_s, value))
        self._lane_now[region] = value

    def chunks(self) -> list[Chunk]:
        """The buffered entries as chunks; the buffer is emptied."""
        out = []
        if self._active:
            out.append(self._states(ACTIVE_STATE, self._active))
            out += self.drawing.chunks(*zip(*self._active, strict=True))
            self._active = []
        for region, rows in self._lanes.items():
            if rows:
                out.append(self._states(level_path(region), rows))
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
