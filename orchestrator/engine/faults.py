"""The fault injector: starts a scenario's faults at their time or on entering their state,
and delivers its scheduled events (`events:`, `run --event`) at their time.

The e-stop is one mechanism whether it is a fault or an event: both call `Executor.event`.
The runner calls `fire_due` from the physics step only when simulated time has reached
`next_t` (one float comparison per step), so a run without faults pays nothing.
"""

from __future__ import annotations

import heapq
import math
from collections.abc import Callable
from functools import partial
from typing import TYPE_CHECKING, Any

import numpy as np

from ..language import faults as F
from ..language.machine import ESTOP
from ..skills.gripper import held_object
from ..world.actuators import ActuatorFault
from ..world.sensors import WristForceFault

if TYPE_CHECKING:
    from ..language.events import ScheduledEvent
    from ..language.faults import Fault
    from .context import Context
    from .executor import Executor

__all__ = ["FaultInjector"]


class FaultInjector:
    """Schedules and applies the faults of one episode.

    Args:
        faults: The scenario's `faults:` (command-line faults included).
        ctx: The episode context (sensors, actuators, perception, the world's effects).
        executor: Receives the events and the e-stop.
        events: The scenario's `events:` (command-line events included).
    """

    def __init__(
        self,
        faults: list[Fault],
        ctx: Context,
        executor: Executor,
        events: list[ScheduledEvent] | None = None,
    ) -> None:
        self.ctx, self.executor = ctx, executor
        self._queue: list[tuple[float, int, Callable[[], object]]] = []
        self._seq = 0
        self._on_enter: dict[str, list[tuple[int, Fault]]] = {}
        self.injected: list[dict[str, Any]] = []
        """`{index, kind, t}` of every fault started, in order."""
        for i, fault in enumerate(faults):
            if fault.at is not None:
                self._schedule(fault.at, self._starter(i, fault))
            else:
                assert fault.on_enter is not None
                self._on_enter.setdefault(fault.on_enter, []).append((i, fault))
        if self._on_enter:  # every entry, the initial state's included (no transition leads there)
            executor.entry_listeners.append(self._on_entry)
        for ev in events or []:
            self._schedule(ev.at, self._sender(ev.event, f"scheduled at t={ev.at:g} s"))

    @property
    def next_t(self) -> float:
        """Simulated time of the next thing to do [s] (inf: nothing scheduled)."""
        return self._queue[0][0] if self._queue else math.inf

    def fire_due(self, t: float) -> None:
        """Apply everything scheduled up to `t` [s]."""
        while self._queue and self._queue[0][0] <= t + 1e-9:
            _, _, action = heapq.heappop(self._queue)
            action()

    def _schedule(self, t: float, action: Callable[[], object]) -> None:
        heapq.heappush(self._queue, (t, self._seq, action))
        self._seq += 1

    def _on_entry(self, path: str, retry: int | None) -> None:
        """A state was entered (`path`, dotted from the root): start the faults keyed on it,
        once, `delay_s` after this first entry."""
        for i, fault in self._on_enter.pop(path, []):
            self._schedule(self.ctx.t + fault.delay_s, self._starter(i, fault))

    # scheduled actions are partials of methods, not closures: what is due is plain data (a
    # snapshot records the queue by index in the scenario, engine/snapshot)
    def _sender(self, name: str, source: str) -> Callable[[], object]:
        return partial(self.executor.event, name, source)

    def _starter(self, index: int, fault: Fault) -> Callable[[], None]:
        return partial(self._start, index, fault)

    def _start(self, index: int, fault: Fault) -> None:
        ctx, t = self.ctx, self.ctx.t
        self.injected.append({"index": index, "kind": fault.kind, "t": round(t, 6)})
        ctx.log("fault", f"fault {fault.kind} injected ({fault.when})", level="WARN")
        effects = ctx.world.effects
        if isinstance(fault, F.EStop):
            self.executor.event(ESTOP, f"injected at t={t:.3f} s")
        elif isinstance(fault, (F.FtDropout, F.FtNan)):
            ctx.cell.wrist.fault = WristForceFault(fault.kind, t, (0.0, 0.0, 0.0), math.inf)
        elif isinstance(fault, F.FtBias):
            fx, fy, fz = fault.force_n
            ctx.cell.wrist.fault = WristForceFault(fault.kind, t, (fx, fy, fz), math.inf)
        elif isinstance(fault, F.FtSpike):
            fx, fy, fz = fault.force_n
            end = t + fault.duration_ms / 1000.0
            ctx.cell.wrist.fault = WristForceFault(fault.kind, t, (fx, fy, fz), end)
        elif isinstance(fault, F.EncoderNoise):
            ctx.cell.encoders.inject(fault.kind, fault.joint, fault.std_rad)
        elif isinstance(fault, (F.EncoderFreeze, F.EncoderNan)):
            ctx.cell.encoders.inject(fault.kind, fault.joint)
        elif isinstance(fault, (F.ActuatorSaturate, F.ActuatorLost)):
            j = fault.joint - 1
            fraction = fault.fraction if isinstance(fault, F.ActuatorSaturate) else 0.0
            limit = float(ctx.world.arm_effort_limit[j])
            ctx.cell.actuator_fault = ActuatorFault(fault.kind, j, limit, fraction)
        elif isinstance(fault, F.ObstacleFault):
            effects.show_obstacle(index)
        elif isinstance(fault, (F.Slip, F.Push)):
            obj = fault.object if fault.object != F.HELD else held_object(ctx)[0]
            if obj is None:
                ctx.log("fault", f"{fault.kind}: nothing in the hand to act on", level="WARN")
            elif isinstance(fault, F.Slip):
                effects.slip(obj, fault.factor)
            else:
                force, name = np.asarray(fault.force_n, float), obj
                effects.push(name, force)
                end = t + fault.duration_ms / 1000.0
                self._schedule(end, partial(effects.end_push, name, force))
        elif isinstance(fault, F.PerceptionMiss):
            ctx.cell.perception.miss(fault.count)
        elif isinstance(fault, F.PerceptionOffset):
            ctx.cell.perception.shift(np.asarray(fault.offset_m, float), fault.count)
        else:  # pragma: no cover - the language's union lists every kind
            raise ValueError(f"unknown fault kind {fault.kind!r}")
