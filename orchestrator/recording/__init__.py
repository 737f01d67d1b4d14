"""Rerun recording of episodes: world geometry and poses, the state machine, signals, events.

`RerunRecorder(path=..., spawn=...)` is a run observer (`run_episode(..., observers=[...])`);
see docs/recording.md for what a recording contains and how it is laid out.
"""

from __future__ import annotations

from .blueprint import default_blueprint
from .exceptions import RecordingError
from .geometry import GeomVisual, geom_archetype, model_geometry, visible_geoms
from .machine_graph import MachineGraph, StateInfo, build_graph
from .recorder import APPLICATION_ID, RerunRecorder

__all__ = [
    "APPLICATION_ID",
    "GeomVisual",
    "MachineGraph",
    "RecordingError",
    "RerunRecorder",
    "StateInfo",
    "build_graph",
    "default_blueprint",
    "geom_archetype",
    "model_geometry",
    "visible_geoms",
]
