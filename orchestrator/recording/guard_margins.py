"""Guards as normalized margins: how close each active guard is to firing, 1.0 = it fires.

Guards watch quantities of different kinds and units (a force against 60 N, a distance to a
joint limit, a count of collisions): drawn raw on one axis, the axis is set by the largest
limit and a 5 N limit is a flat line at the bottom. Each guard's monitored value
(`Guard.monitored`: value and limit) is therefore turned into a utilisation `u` (`utilisation`):
0 far from firing, 1.0 at the limit, above 1 past it, and plotted at `guards/<guard>` against
a trip line at 1.0 (`guards/trip`). The raw value and limit stay in the recording, at
`guard_values/<guard>` (a tab behind the margins in the default layout).

Peaks are kept: a guard in `STEP_PEAK_GUARDS` (a force reading can spike within one control
tick) is read after every physics step and its row holds the largest `u` since the last row.
The value that fired a guard is logged at the very instant it fired (`guards/<guard>/tripped`,
a marker), not at the next control tick. The viewer draws a margin by its largest value per
pixel column (`aggregation_policy` Max), the raw values by their least and largest: a one-tick
peak stays visible however long the run.

A guard's lines exist only while the guard is active: the tick a state that held it is left,
`guards/<guard>` and `guard_values/<guard>` are cleared (`rr.Clear`, which the time series view
draws as a break), so a guard of one state is not drawn as a flat line through the whole run.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
import rerun as rr
from rerun.chunk import Chunk

from ..language.machine import guard_entries
from .batches import StaticBatch, TemporalBatch, scalar_lists
from .paths import GUARD_VALUES, GUARDS, part
from .timeline import time_columns

if TYPE_CHECKING:
    from ..engine.context import Context
    from ..guards.base import Guard
    from ..language.loading import MachineNode

__all__ = [
    "KINDS",
    "STEP_PEAK_GUARDS",
    "TRIP_LINE",
    "UNITS",
    "GuardMargins",
    "Normalizer",
    "declared_guards",
    "normalizer",
    "unit_of",
]

TRIP_LINE = f"{GUARDS}/trip"
"""The constant 1.0 every margin is drawn against."""
STEP_PEAK_GUARDS = frozenset({"contact_force", "sensor_health"})
"""Guards read after every physics step for their per-tick peak. Both read the wrist force,
which the guard bank reads every step while they are active (a cached reading: reading it
first costs ~0.5 us and changes nothing), and both fire above their limit (their largest
value is their largest margin). The other guards watch positions and velocities, which move
little within a 10 ms tick; they are sampled per tick."""
_U_CAP = 10.0
"""Utilisation is capped here (a lower bound of a quantity that falls to 0: infinite)."""
_TRIP_COLOR = 0xD62728FF
_PALETTE = (
    0x4E79A7FF, 0xF28E2BFF, 0x59A14FFF, 0xB07AA1FF, 0x76B7B2FF, 0xEDC948FF, 0x9C755FFF,
    0xFF9DA7FF, 0xBAB0ACFF, 0x1F77B4FF,
)  # fmt: skip
_SCALARS = rr.Scalars.descriptor_scalars()
_MARGIN_AGGREGATION = rr.components.AggregationPolicy.Max
"""A margin's largest value per pixel column: the closest the guard came to firing."""
_VALUE_AGGREGATION = rr.components.AggregationPolicy.MinMax
"""A raw value's least and largest per pixel column (a lower-bound guard fires on the least)."""
_CLEAR_AFTER_S = 1e-6
"""A clear at the same instant as the guard's last row would hide that row: it goes this much
later [s] (still before the next control tick)."""


@dataclass(frozen=True)
class Normalizer:
    """How a guard's monitored value maps to its utilisation.

    Attributes:
        kind: `upper` (the guard fires above `limit`: u = value / limit), `lower` (it fires
            below a positive `limit`: u = limit / value), or `distance` (value is a distance to
            a boundary the guard fires at, `limit` its margin: u rises from 0 at `reach` from
            the limit to 1.0 at it: u = 1 - (value - limit) / reach).
        reach: For `distance`: how far from the limit the margin starts to rise, in the
            value's unit ([m] or [rad]).
    """

    kind: str
    reach: float = 0.1

    def __call__(self, value: float, limit: float) -> float:
        """The utilisation of `value` against `limit` (1.0 = the guard fires there)."""
        if not math.isfinite(value):
            return _U_CAP
        if self.kind == "upper":
            u = value / limit if limit > 0 else (1.0 + value if value > limit else 0.0)
        elif self.kind == "lower":
            u = limit / value if value > 0 else _U_CAP
        else:
            u = 1.0 - (value - limit) / self.reach
        return min(max(u, 0.0), _U_CAP)


KINDS: dict[str, Normalizer] = {
    "contact_force": Normalizer("upper"),
    "sensor_health": Normalizer("upper"),
    "joint_torque": Normalizer("upper"),
    "joint_velocity": Normalizer("upper"),
    "joint_acceleration": Normalizer("upper"),
    "path_deviation": Normalizer("upper"),
    "collision": Normalizer("upper"),  # contacts counted against 0: any contact is >= 1.0
    "grasp_lost": Normalizer("lower"),
    "joint_limits": Normalizer("distance", reach=0.3),  # [rad] to the nearest joint limit
    "workspace": Normalizer("distance", reach=0.1),  # [m] to the nearest face of the box
    "no_go_zone": Normalizer("distance", reach=0.05),  # [m] to the zone, past its margin
}
"""The bundled guards. A guard not listed: `upper` if its limit is positive, else `distance`
with a reach of 0.1."""


UNITS: dict[str, str] = {
    "contact_force": "N",
    "sensor_health": "N",
    "joint_torque": "share of limit",  # the joint nearest its own limit: |tau| / limit
    "joint_velocity": "share of limit",
    "joint_acceleration": "share of limit",
    "path_deviation": "m",
    "grasp_lost": "m",  # the gripper's opening against the least it may close to
    "joint_limits": "rad",
    "workspace": "m",
    "no_go_zone": "m",
    "collision": "contacts",
}
"""The unit of each bundled guard's raw value and limit (`guard_values/<guard>`). A guard not
listed has its own panel, named after it."""


def unit_of(key: str) -> str:
    """The unit of guard `key`'s raw value (`<name>` or `<name>_<n>`); its name if unknown."""
    name = key if key in UNITS else key.rsplit("_", 1)[0]
    return UNITS.get(name, key)


def declared_guards(
    root: MachineNode, active: list[Guard], scenario: dict[str, Any] | None = None
) -> list[str]:
    """The names of every guard a run of `root` can activate: the scenario's (`guards:`),
    those active as it starts, and those its machines and states declare."""
    names = {name: None for _, name, _ in guard_entries(scenario or {})}
    names.update({g.name: None for g in active})
    for node in root.nodes():
        names.update({name: None for _, name, _ in guard_entries(node.guards)})
        for spec in node.states.values():
            refs = getattr(spec, "guards", None) or []
            names.update({name: None for _, name, _ in guard_entries(refs)})
    return list(names)


def normalizer(guard: str, limit: float) -> Normalizer:
    """How the utilisation of guard `guard` (its name) with limit `limit` is computed."""
    found = KINDS.get(guard)
    if found is not None:
        return found
    return Normalizer("upper") if limit > 0 else Normalizer("distance")


@dataclass
class _Plan:
    """One active guard: where its rows go and how its value is read."""

    key: str
    name: str
    monitored: Callable[[Context], tuple[float, float] | None]
    rows: list[tuple[int, float, float, float, float]]
    """(tick, t [s], u, value, limit)."""
    step: bool
    peak: tuple[float, float] | None = None
    """Largest (value, limit) read since the last row (step-sampled guards)."""


class GuardMargins:
    """Each active guard's utilisation per control tick (with its per-step peak), the raw
    value next to its limit, and the value that fired a guard at its instant.

    Guards are told apart by name; a second active guard of the same name (a state-level
    guard next to a machine-level one) is `<name>_2`.
    """

    def __init__(self) -> None:
        self._rows: dict[str, list[tuple[int, float, float, float, float]]] = {}
        self._styled: set[str] = set()
        self._active: tuple[Guard, ...] = ()
        self._plans: list[_Plan] = []
        self._step: list[_Plan] = []
        self._trips: list[tuple[str, int, float, float, float, float]] = []
        """(key, tick, t [s], u, value, limit) of each guard that fired."""
        self._trip_line: list[tuple[int, float]] = []
        self._last: dict[str, tuple[int, float]] = {}
        """(tick, t [s]) of each guard's last row."""
        self._clears: list[tuple[str, int, float]] = []
        """(key, tick, t [s]) of each guard that stopped being active."""

    # -- sampling -------------------------------------------------------------------------
    def plan(self, guards: list[Guard], tick: int = 0, t_s: float = 0.0) -> None:
        """The active guards at control tick `tick`, time `t_s` [s]. If they changed (a state
        was entered), plan their keys and reads; a guard no longer active is cleared then."""
        if tuple(guards) == self._active:
            return
        self._active = tuple(guards)
        before = {p.key for p in self._plans}
        kept = {p.key: p.peak for p in self._plans}  # peaks of guards that stay active
        seen: dict[str, int] = {}
        self._plans = []
        for guard in guards:
            count = seen.get(guard.name, 0) + 1
            seen[guard.name] = count
            key = guard.name if count == 1 else f"{guard.name}_{count}"
            rows = self._rows.setdefault(key, [])
            plan = _Plan(key, guard.name, guard.monitored, rows, guard.name in STEP_PEAK_GUARDS)
            plan.peak = kept.get(key)
            self._plans.append(plan)
        self._step = [p for p in self._plans if p.step]
        for key in sorted(before - {p.key for p in self._plans}):
            last_tick, last_t = self._last.get(key, (-1, -math.inf))
            t_clear = t_s if t_s > last_t else last_t + _CLEAR_AFTER_S
            self._clears.append((key, max(tick, last_tick), t_clear))

    def on_step(self, ctx: Context) -> None:
        """After a physics step: keep the largest value of every step-sampled guard."""
        for p in self._step:
            watched = p.monitored(ctx)
            if watched is not None and (p.peak is None or watched[0] > p.peak[0]):
                p.peak = watched

    @property
    def stepping(self) -> bool:
        """Whether a step-sampled guard is active (`on_step` has anything to do)."""
        return bool(self._step)

    def sample(self, tick: int, t_s: float, ctx: Context) -> None:
        """A control tick: one row per active guard with a scalar. A step-sampled guard's
        row is its peak over the physics steps since the last row, read only in `on_step`:
        the wrist force it reads carries the sensor's noise, drawn anew at each instant it is
        read, so reading it at an instant the guard bank did not (the tick before the first
        step) would change the run."""
        for p in self._plans:
            if p.step:
                watched, p.peak = p.peak, None
            else:
                watched = p.monitored(ctx)
            if watched is None:
                continue
            value, limit = float(watched[0]), float(watched[1])
            p.rows.append((tick, t_s, normalizer(p.name, limit)(value, limit), value, limit))
            self._last[p.key] = (tick, t_s)

    def tripped(
        self, tick: int, t_s: float, ctx: Context, guard: str, value: object, limit: object
    ) -> None:
        """Guard `guard` fired at time `t_s` [s] (during control tick `tick`, `ctx` as it was
        then) with `value` against `limit`: a marker at that instant, at the utilisation the
        guard's monitored value had then (a scalar violation value is marked as it is)."""
        plan = next((p for p in self._plans if p.name == guard), None)
        key = plan.key if plan is not None else guard
        v, lim = _scalar(value), _scalar(limit)
        if plan is None:
            watched = None
        else:  # a step-sampled guard was read at this very step (on_step runs before checks)
            watched = plan.peak if plan.step else plan.monitored(ctx)
        if watched is not None:
            u = normalizer(guard, float(watched[1]))(float(watched[0]), float(watched[1]))
            if not math.isfinite(v + lim):
                v, lim = float(watched[0]), float(watched[1])
        else:
            u = normalizer(guard, lim)(v, lim) if math.isfinite(v + lim) else 1.0
        u = max(u, 1.0)
        self._rows.setdefault(key, []).append((tick, t_s, u, v, lim))  # the line reaches it
        self._last[key] = (tick, t_s)
        self._trips.append((key, tick, t_s, u, v, lim))

    def trip_line(self, tick: int, t_s: float) -> None:
        """Extend the trip line at 1.0 to `t_s` [s]."""
        self._trip_line.append((tick, t_s))

    # -- sending --------------------------------------------------------------------------
    def chunks(self) -> list[Chunk]:
        """The buffered rows as chunks (guards sampled at the same ticks share one batch); the
        buffers are emptied."""
        static = StaticBatch()
        batches: dict[bytes, TemporalBatch] = {}
        for key, rows in self._rows.items():
            self._style(static, key)
            if not rows:
                continue
            table = np.array(rows, dtype=np.float64)
            ticks = table[:, 0].astype(np.int64)
            batch = batches.get(ticks.tobytes())
            if batch is None:
                batch = batches[ticks.tobytes()] = TemporalBatch(ticks, table[:, 1])
            batch.add(f"{GUARDS}/{part(key)}", _SCALARS, scalar_lists(table[:, 2]))
            batch.add(f"{GUARD_VALUES}/{part(key)}", _SCALARS, scalar_lists(table[:, 3:5]))
            rows.clear()
        out = static.chunks()
        for batch in batches.values():
            out += batch.chunks()
        if self._trip_line:
            line_ticks, line_t = (np.array(c) for c in zip(*self._trip_line, strict=True))
            out.append(
                Chunk.from_columns(
                    TRIP_LINE,
                    indexes=time_columns(line_ticks, line_t),
                    columns=rr.Scalars.columns(scalars=np.ones(len(line_ticks))),
                )
            )
            self._trip_line = []
        for key, tick, t_s, u, value, limit in self._trips:
            out += _trip_chunks(key, tick, t_s, u, value, limit)
        self._trips = []
        for key, tick, t_s in self._clears:
            index = time_columns(np.array([tick]), np.array([t_s]))
            for entity in (f"{GUARDS}/{part(key)}", f"{GUARD_VALUES}/{part(key)}"):
                out.append(
                    Chunk.from_columns(
                        entity, indexes=index, columns=rr.Clear.columns(is_recursive=[False])
                    )
                )
        self._clears = []
        return out

    def _style(self, static: StaticBatch, key: str) -> None:
        if key in self._styled:
            return
        if not self._styled:
            static.log(TRIP_LINE, rr.SeriesLines(names=["fires (1.0)"], colors=[_TRIP_COLOR]))
        color = _PALETTE[len(self._styled) % len(_PALETTE)]
        static.log(
            f"{GUARDS}/{part(key)}",
            rr.SeriesLines(names=[key], colors=[color], aggregation_policy=_MARGIN_AGGREGATION),
        )
        static.log(
            f"{GUARD_VALUES}/{part(key)}",
            rr.SeriesLines(
                names=[f"{key} value", f"{key} limit"],
                colors=[color, _TRIP_COLOR],
                aggregation_policy=_VALUE_AGGREGATION,
            ),
        )
        self._styled.add(key)


def _scalar(value: object) -> float:
    try:
        return float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return math.nan


def _trip_chunks(
    key: str, tick: int, t_s: float, u: float, value: float, limit: float
) -> list[Chunk]:
    """The marker of a guard that fired: on the margins (at u) and on the raw values."""
    index = time_columns(np.array([tick]), np.array([t_s]))
    name = f"{key} fired: {value:.4g} (limit {limit:.4g})" if math.isfinite(value) else key
    out = []
    for entity, y in ((f"{GUARDS}/{part(key)}/tripped", u),
                      (f"{GUARD_VALUES}/{part(key)}/tripped", value)):  # fmt: skip
        if not math.isfinite(y):
            continue
        out.append(
            Chunk.from_columns(
                entity,
                indexes=index,
                columns=[
                    *rr.Scalars.columns(scalars=[y]),
                    *rr.SeriesPoints.columns(
                        markers=["Cross"], marker_sizes=[8.0], colors=[_TRIP_COLOR], names=[name]
                    ),
                ],
            )
        )
    return out
