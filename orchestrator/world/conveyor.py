"""A conveyor belt in the MuJoCo world: the belt, its light barrier and the parcel feed.

MuJoCo has no moving surfaces, so the belt is a fixed box and its drive is kinematic: every
physics step, while the belt runs, each parcel resting on it gets the belt's velocity (in the
table plane; no spin) — a belt that grips its parcels without slip, which is what a rubber
belt does to a box of a few hundred grams. Stopped, the belt is a still surface with friction.
The alternative, a plate on a driven slide joint carrying the parcels by friction, runs out
of travel and would have to be teleported back with the parcels on it.

The light barrier is a ray across the belt at the pick zone (`mj_ray`, dynamic geoms only):
a parcel — or a hand — in the beam stops the belt at the next scan (every `SCAN_STEPS`
physics steps, 10 ms at the default 2 ms step, a PLC's cycle); a clear beam starts it again.

A MuJoCo model cannot grow during a run, so the parcels are a fixed pool of bodies: when the
feed needs a parcel, the oldest body whose parcel is finished (in a bin, on the floor, passed
off the belt's end, at rest and no longer the flow's task) is judged in the task log, then
taken back to the feed with a new class, size and mass drawn from the seed and the parcel's
number. A shift of any length has the same bodies, and its memory does not grow with it.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any, Protocol

import mujoco
import numpy as np

from ..robots.panda.model import WORLD_CONAFFINITY, WORLD_CONTYPE
from .pool import parcel_id, pool_body_name
from .pose import quat_from_yaw
from .random_streams import stream

if TYPE_CHECKING:
    from ..language.conveyor_scene import Conveyor


class _Body(Protocol):
    """What the belt uses of a free object's handle (world.ObjectHandle)."""

    name: str
    body_id: int
    qpos_adr: int
    qvel_adr: int
    geom_id: int
    half_size: np.ndarray


class _World(Protocol):
    """What the belt uses of the world (named here: world.py holds the belt)."""

    model: mujoco.MjModel
    data: mujoco.MjData
    seed: int
    objects: Any
    parcel_classes: dict[str, str]


class _Context(Protocol):
    """What the belt uses of the running episode (the engine's Context has it)."""

    tasks: Any
    metrics: dict[str, Any]

    def log(self, kind: str, message: str, level: str = "INFO", **data: Any) -> None: ...


__all__ = ["BELT_GEOM", "SCAN_STEPS", "ConveyorBelt", "add_conveyor"]

BELT_GEOM = "conveyor_belt"
SCAN_STEPS = 5
"""Physics steps between two scans of the light barrier and the feed (10 ms at 2 ms)."""
_FEED_BACK_M = 0.06
"""Belt behind the feed point [m]."""
_ON_BELT_Z_M = 0.006
"""A parcel's bottom this close to the belt's top rests on it [m]."""
_AT_REST_M_S = 0.03
"""A body slower than this is at rest [m/s]."""


def _frame(c: Conveyor) -> tuple[np.ndarray, np.ndarray, np.ndarray, float, float]:
    """`(feed xy, unit direction u, unit normal n (left of u), start s [m], end s [m])`: the
    belt spans `feed + s u` for s in [start, end]."""
    feed = np.asarray(c.feed_xy, float)
    u = np.asarray(c.direction(), float)
    n = np.array([-u[1], u[0]])
    return feed, u, n, -_FEED_BACK_M, c.travel_m() + c.overrun_m


def add_conveyor(spec: mujoco.MjSpec, c: Conveyor) -> None:
    """Add the belt (a fixed box from the floor to `top_height_m`) and the barrier's posts."""
    feed, u, n, s0, s1 = _frame(c)
    mid = feed + u * (s0 + s1) / 2
    yaw = math.atan2(u[1], u[0])
    wb = spec.worldbody
    belt = wb.add_geom(
        name=BELT_GEOM,
        type=mujoco.mjtGeom.mjGEOM_BOX,
        pos=[mid[0], mid[1], c.top_height_m / 2],
        quat=quat_from_yaw(yaw).tolist(),
        size=[(s1 - s0) / 2, c.width_m / 2, c.top_height_m / 2],
    )
    belt.rgba = [0.18, 0.18, 0.2, 1.0]
    belt.friction = [c.friction, 0.005, 0.0001]
    belt.contype, belt.conaffinity = WORLD_CONTYPE, WORLD_CONAFFINITY
    pick = np.asarray(c.pick_xy, float)
    for side in (-1.0, 1.0):  # the barrier's two posts: emitter and receiver (visual only)
        at = pick + n * side * (c.width_m / 2 + 0.015)
        post = wb.add_geom(
            name=f"light_barrier_{'r' if side < 0 else 'l'}",
            type=mujoco.mjtGeom.mjGEOM_BOX,
            pos=[at[0], at[1], c.top_height_m + 0.03],
            size=[0.008, 0.008, 0.03],
        )
        post.rgba = [0.95, 0.75, 0.1, 1.0]
        post.contype, post.conaffinity = 0, 0
        post.group = 3


class ConveyorBelt:
    """The running belt of one episode: drive, light barrier, feed and the pool of bodies.

    Args:
        world: The compiled world (its objects include the pool bodies).
        conveyor: The belt's scenario key.

    Attributes:
        fed: Parcels fed so far.
        blocked: The light barrier's beam is interrupted (at the last scan).
        running: The belt moves.
        passing: The belt runs through a blocked beam until it is clear (`pass_through`).
        feed_waits: Scans at which the feed was due but no body was free.
    """

    def __init__(self, world: _World, conveyor: Conveyor) -> None:
        self.c = conveyor
        self.world = world
        self.model, self.data = world.model, world.data
        self.slots: list[_Body] = [world.objects[pool_body_name(i)] for i in range(conveyor.pool)]
        self.ids: list[str | None] = [None] * conveyor.pool
        """Each body's parcel id (None: parked, never fed)."""
        self.order: list[int] = []
        """Bodies in the order their parcels were fed (oldest first)."""
        self.fed = 0
        self.blocked = False
        self.running = True
        self.passing = False
        self.feed_waits = 0
        self._steps = 0
        self._last: int | None = None
        self._on_belt: list[int] = []
        self._feed, self._u, self._n, self._s0, self._s1 = _frame(conveyor)
        self._fx, self._fy = (float(v) for v in self._feed)
        self._ux, self._uy = (float(v) for v in self._u)
        self._nx, self._ny = (float(v) for v in self._n)
        self._half_width = conveyor.width_m / 2
        self._top = conveyor.top_height_m
        self._v = self._u * conveyor.speed_m_s
        pick = np.asarray(conveyor.pick_xy, float)
        reach = conveyor.width_m / 2 + 0.03
        z = self._top + conveyor.barrier_height_m
        self._ray_from = np.array([*(pick - self._n * reach), z])
        self._ray_dir = np.array([*self._n, 0.0])
        self._ray_len = 2 * reach
        self._geomid = np.zeros(1, np.int32)
        for h in self.slots:
            world.parcel_classes[h.name] = next(iter(conveyor.classes))

    # -- what the flow and the task log read ------------------------------------------------
    def parcel_id(self, body: str) -> str | None:
        """The id of the parcel `body` carries now (None: a parked body)."""
        for h, pid in zip(self.slots, self.ids, strict=True):
            if h.name == body:
                return pid
        return None

    def active(self) -> list[tuple[str, str]]:
        """`(body, parcel id)` of every body carrying a parcel, oldest first."""
        return [(self.slots[i].name, self.ids[i] or "") for i in self.order]

    @property
    def shift_over(self) -> bool:
        """Every parcel of the shift was fed and none is on the belt or in the beam."""
        return self.fed >= self.c.parcels and not self._on_belt and not self.blocked

    @property
    def waiting(self) -> bool:
        """A parcel is in the pick zone: the beam is blocked and the belt stopped."""
        return self.blocked and not self.running

    def on_belt(self, pos: list[float], half_height: float) -> bool:
        """The body at `pos` [m] (its half height [m]) rests on the belt.

        Plain float arithmetic (`pos` a list): numpy on 2-vectors cost 72 us a body.
        """
        x, y = pos[0] - self._fx, pos[1] - self._fy
        s = x * self._ux + y * self._uy
        d = x * self._nx + y * self._ny
        return (
            self._s0 <= s <= self._s1
            and abs(d) <= self._half_width
            and abs(pos[2] - half_height - self._top) <= _ON_BELT_Z_M
        )

    def pass_through(self) -> None:
        """Run the belt through the blocked beam until it clears (a rejected parcel goes on,
        off the belt's end)."""
        self.passing = True

    # -- every physics step ----------------------------------------------------------------
    def on_step(self, ctx: _Context) -> None:
        """Drive the parcels on the running belt; every `SCAN_STEPS` scan the barrier and feed."""
        if self.running and self._on_belt:
            qvel = self.data.qvel
            vx, vy = self._v
            for i in self._on_belt:
                a = self.slots[i].qvel_adr
                qvel[a] = vx
                qvel[a + 1] = vy
                qvel[a + 3 : a + 6] = 0.0
        self._steps += 1
        if self._steps % SCAN_STEPS:
            return
        self._scan(ctx)

    def _scan(self, ctx: _Context) -> None:
        qpos = self.data.qpos
        on_belt = []
        for i in self._on_belt:  # a parcel leaves the belt for good (picked, passed, fallen)
            h = self.slots[i]
            a = h.qpos_adr
            if self.on_belt(qpos[a : a + 3].tolist(), float(h.half_size[2])):
                on_belt.append(i)
        self._on_belt = on_belt
        dist = mujoco.mj_ray(
            self.model, self.data, self._ray_from, self._ray_dir, None, 0, -1, self._geomid
        )
        blocked = 0.0 <= dist <= self._ray_len
        if blocked != self.blocked:
            self.blocked = blocked
            ctx.log("conveyor", f"light barrier {'blocked' if blocked else 'clear'}")
        if self.passing and not blocked:
            self.passing = False
        running = not blocked or self.passing
        if running != self.running:
            self.running = running
            if not running:
                for i in self._on_belt:  # the belt stops: what it carries stops with it
                    a = self.slots[i].qvel_adr
                    self.data.qvel[a : a + 6] = 0.0
        if self.fed < self.c.parcels and self._feed_due():
            self._feed_next(ctx)

    def _feed_due(self) -> bool:
        if self._last is None:
            return True
        if self.passing:
            return False  # the belt runs through the beam: feed once it is clear
        h = self.slots[self._last]
        pos = self.data.qpos[h.qpos_adr : h.qpos_adr + 2]
        return float((pos - self._feed) @ self._u) >= self.c.spacing_m or self._last not in (
            self._on_belt
        )

    def _free_slot(self, ctx: _Context) -> int | None:
        """A parked body, else the oldest whose parcel is finished and at rest."""
        for i, pid in enumerate(self.ids):
            if pid is None:
                return i
        qvel = self.data.qvel
        for i in self.order:
            if i in self._on_belt or i == self._last:
                continue
            a = self.slots[i].qvel_adr
            if float(np.linalg.norm(qvel[a : a + 3])) > _AT_REST_M_S:
                continue
            entry = ctx.tasks.entries.get(self.ids[i] or "")
            if entry is not None and entry.start_t is not None and entry.flow is None:
                continue  # the flow's open task: in the hand, or being tried again
            return i
        return None

    def _feed_next(self, ctx: _Context) -> None:
        i = self._free_slot(ctx)
        if i is None:  # every body is busy: the feed waits (a pool too small for the cell)
            self.feed_waits += 1
            wait_s = self.feed_waits * SCAN_STEPS * float(self.model.opt.timestep)
            ctx.metrics["feed_wait_s"] = round(wait_s, 3)
            return
        h = self.slots[i]
        if self.ids[i] is not None:
            ctx.tasks.judge(ctx, h.name)
            self.order.remove(i)
        k = self.fed
        c = self.c
        rng = stream(self.world.seed, "conveyor_feed", k)
        classes = list(c.classes)
        cls = classes[int(rng.integers(len(classes)))]
        size = np.array(
            [
                rng.uniform(c.length_m[0], c.length_m[1]),
                rng.uniform(c.parcel_width_m[0], c.parcel_width_m[1]),
                rng.uniform(c.height_m[0], c.height_m[1]),
            ]
        )
        mass = float(rng.uniform(c.mass_kg[0], c.mass_kg[1]))
        yaw = math.atan2(self._u[1], self._u[0]) + math.radians(
            float(rng.uniform(-c.yaw_jitter_deg, c.yaw_jitter_deg))
        )
        lateral = float(rng.uniform(-c.lateral_jitter_m, c.lateral_jitter_m))
        self._reshape(h, size, mass, c.classes[cls])
        xy = self._feed + self._n * lateral
        q, v = self.data.qpos, self.data.qvel
        q[h.qpos_adr : h.qpos_adr + 3] = [xy[0], xy[1], self._top + size[2] / 2 + 0.0005]
        q[h.qpos_adr + 3 : h.qpos_adr + 7] = quat_from_yaw(yaw)
        v[h.qvel_adr : h.qvel_adr + 6] = 0.0
        pid = parcel_id(k, c.parcels)
        self.ids[i] = pid
        self.world.parcel_classes[h.name] = cls
        self.order.append(i)
        self._on_belt.append(i)
        self._last = i
        self.fed += 1
        ctx.metrics["parcels_fed"] = self.fed
        ctx.metrics["shift_parcels"] = c.parcels
        ctx.log("conveyor", f"{pid} ({cls}) fed on {h.name}, {self.fed}/{c.parcels}")

    def _reshape(self, h: _Body, size: np.ndarray, mass: float, rgba: list[float]) -> None:
        """Give body `h` a new box `size` [m] (shape (3,)), `mass` [kg] and colour."""
        m, g, b = self.model, h.geom_id, h.body_id
        half = size / 2
        m.geom_size[g] = half
        m.geom_rbound[g] = float(np.linalg.norm(half))
        m.geom_aabb[g] = [0.0, 0.0, 0.0, *half]
        m.geom_rgba[g] = rgba
        inertia = (
            mass
            / 12.0
            * np.array(
                [
                    size[1] ** 2 + size[2] ** 2,
                    size[0] ** 2 + size[2] ** 2,
                    size[0] ** 2 + size[1] ** 2,
                ]
            )
        )
        m.body_mass[b] = mass
        m.body_subtreemass[b] = mass
        m.body_inertia[b] = inertia
        # the constraint solver's scaling of this body (mj_setConst at compile time)
        m.body_invweight0[b] = [1.0 / mass, float(np.mean(1.0 / inertia))]
        d = m.body_dofadr[b]
        m.dof_invweight0[d : d + 3] = 1.0 / mass
        m.dof_invweight0[d + 3 : d + 6] = 1.0 / inertia
        # the mass matrix's diagonal at qpos0, which MuJoCo 4 uses for free bodies: left at
        # the compiled mass, gravity (from the new mass) pulled a 0.4 kg parcel compiled at
        # 0.05 kg down at 8 g, and it struck the table at 4.8 m/s from 17 cm (23 mm deep)
        m.dof_M0[d : d + 3] = mass
        m.dof_M0[d + 3 : d + 6] = inertia
        h.half_size[:] = half
