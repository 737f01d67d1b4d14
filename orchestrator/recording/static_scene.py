"""Everything static of an episode, built once per (model, machine, scene markers).

Episodes of one scenario share their static scene: the geometry, the poses of bodies welded to
the world, the marker and TCP frames, the machine's state colours and graph, the plot styles.
A batch worker builds it for its first episode and reuses it for the next ones.
"""

from __future__ import annotations

from collections import OrderedDict
from dataclasses import dataclass
from typing import TYPE_CHECKING

import rerun as rr
from rerun.chunk import Chunk

from .batches import StaticBatch
from .geometry import GeomVisual
from .geometry_chunks import geometry_chunks, model_signature
from .machine_graph import MachineGraph, build_graph
from .paths import WORLD
from .poses import BodyPoses
from .signals import RobotSignals
from .state_log import StateLog
from .targets import Targets

if TYPE_CHECKING:
    from ..engine.context import Context
    from ..language.loading import MachineNode

__all__ = ["StaticScene", "reshaped_geoms", "static_scene"]

_CACHE_SIZE = 8


@dataclass(frozen=True)
class StaticScene:
    """The static part of a recording.

    Attributes:
        chunks: Static chunks: geometry, world frame, static bodies, frames, machine, styles.
        poses: Which bodies are logged, at which entity paths (read-only once built).
        graph: The machine tree's graph.
        skipped: Visible geoms that cannot be drawn (SDF geoms without a mesh).
        root: The machine the scene was built for (kept to recognise it).
        reshaped: The geoms the run may reshape, drawn on the timeline (recording/reshaped.py).
    """

    chunks: list[Chunk]
    poses: BodyPoses
    graph: MachineGraph
    skipped: list[int]
    root: MachineNode
    reshaped: tuple[GeomVisual, ...] = ()


_cache: OrderedDict[tuple, StaticScene] = OrderedDict()


def _key(ctx: Context, root: MachineNode) -> tuple:
    markers = tuple((name, tuple(float(v) for v in pos)) for name, pos in ctx.world.markers.items())
    styles = tuple(
        (mk.name, tuple(mk.size_xy), tuple(mk.rgba)) for mk in ctx.scenario.scene.markers
    )
    joints = tuple(getattr(ctx.robot, "arm_joints", ()))
    return (
        model_signature(ctx.model),
        id(root),
        markers,
        styles,
        joints,
        ctx.world.tcp_site,
        tuple(sorted(reshaped_geoms(ctx))),
    )


def reshaped_geoms(ctx: Context) -> frozenset[int]:
    """Geoms the run may reshape or recolour: a conveyor's recycled parcel bodies."""
    conveyor = ctx.world.conveyor
    if conveyor is None:
        return frozenset()
    return frozenset(int(slot.geom_id) for slot in conveyor.slots)


def static_scene(ctx: Context, root: MachineNode) -> StaticScene:
    """The static scene of the episode in `ctx` running `root`, cached (last few scenes)."""
    key = _key(ctx, root)
    hit = _cache.get(key)
    if hit is not None and hit.root is root:
        _cache.move_to_end(key)
        return hit
    geometry = geometry_chunks(ctx.model, reshaped_geoms(ctx))
    static = StaticBatch()
    static.log(WORLD, rr.ViewCoordinates.RIGHT_HAND_Z_UP)
    poses = BodyPoses(ctx.model, geometry.bodies)
    Targets().log_static(static, ctx, poses)
    poses.log_static(static, ctx.data)
    graph = build_graph(root)
    StateLog(graph).log_static(static)
    RobotSignals(ctx).log_static(static)
    scene = StaticScene(
        chunks=[*geometry.chunks, *static.chunks()],
        poses=poses,
        graph=graph,
        skipped=list(geometry.skipped),
        root=root,
        reshaped=geometry.reshaped,
    )
    _cache[key] = scene
    while len(_cache) > _CACHE_SIZE:
        _cache.popitem(last=False)
    return scene
