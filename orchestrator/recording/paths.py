"""Entity paths and timeline names of a recording: the layout the blueprint and tests rely on."""

from __future__ import annotations

import re

__all__ = [
    "ACTIVE_STATE",
    "BODIES",
    "CAMERAS",
    "EVENTS",
    "GEOMS",
    "GRAPH",
    "GUARDS",
    "GUARD_VALUES",
    "LEVELS",
    "RESULT",
    "ROUTES",
    "ROUTE_HEADS",
    "SIGNALS",
    "SIM_TIME",
    "STATE_MACHINE",
    "TARGETS",
    "TICK",
    "WORLD",
    "body_path",
    "frame_path",
    "geom_path",
    "level_path",
    "part",
]

SIM_TIME = "sim_time"
"""Duration timeline: simulated time since the episode started (the primary timeline)."""
TICK = "tick"
"""Sequence timeline: control tick index (100 Hz by default)."""

WORLD = "world"
BODIES = f"{WORLD}/bodies"
"""`<BODIES>/<body>`: one MuJoCo body's pose in the world frame."""
GEOMS = "geoms"
"""`<BODIES>/<body>/<GEOMS>/<geom>`: one geom, posed relative to its body."""
CAMERAS = f"{WORLD}/cameras"
"""`<CAMERAS>/<camera>`: a camera's pose and pinhole; `rgb`, `depth`, `segmentation` and
`detections` below it, logged at each frame a skill looked at."""
TARGETS = f"{WORLD}/targets"
"""`<TARGETS>/ik_target` and one frame per scene marker."""
STATE_MACHINE = "state_machine"
ACTIVE_STATE = f"{STATE_MACHINE}/active"
"""StateChange of the active leaf state, by dotted path (`PICK.SEARCH`)."""
LEVELS = f"{STATE_MACHINE}/levels"
"""`<LEVELS>/depth_<d>`: StateChange of each nesting depth (`depth_0` the top level)."""
GRAPH = f"{STATE_MACHINE}/graph"
"""GraphNodes/GraphEdges of the machine tree, the active states highlighted over time."""
ROUTES = f"{GRAPH}/_routes"
"""The machine graph's arrows bent along Graphviz's routes (graph_routes.py): the pieces
before the last, as invisible points joined by undirected edges."""
ROUTE_HEADS = f"{GRAPH}/_route_heads"
"""The last piece of each bent arrow, directed (its arrowhead at the target state)."""
SIGNALS = "signals"
GUARDS = "guards"
"""`<GUARDS>/<guard>`: each guard's utilisation (1.0 = it fires), `<GUARDS>/trip` the line at
1.0, `<GUARDS>/<guard>/tripped` the instant a guard fired."""
GUARD_VALUES = "guard_values"
"""`<GUARD_VALUES>/<guard>`: each guard's raw monitored value next to its limit."""
EVENTS = "events"
RESULT = "run/result"
"""A static TextDocument: how the run ended and why (while it runs: that it runs)."""
"""`<EVENTS>/<kind>`: TextLog per event kind (transition, outcome, retry, violation, ...)."""

_UNSAFE = re.compile(r"[^A-Za-z0-9_\-.]")


def part(name: str) -> str:
    """One entity-path part from a free-form name (characters outside `[A-Za-z0-9_-.]` -> `_`)."""
    return _UNSAFE.sub("_", name) or "_"


def body_path(name: str) -> str:
    """Entity path of a body's frame."""
    return f"{BODIES}/{part(name)}"


def geom_path(body: str, geom: str) -> str:
    """Entity path of a geom under its body."""
    return f"{body_path(body)}/{GEOMS}/{part(geom)}"


def frame_path(owner: str) -> str:
    """Entity path of the frame around the machine nested in state `owner` in the graph
    (`PICK.GRASP` -> `state_machine/graph/PICK/GRASP`)."""
    return "/".join([GRAPH, *(part(p) for p in owner.split("."))])


def level_path(depth: int) -> str:
    """Entity path of the state lane of nesting depth `depth` (`depth_0` is the top level)."""
    return f"{LEVELS}/depth_{depth}"
