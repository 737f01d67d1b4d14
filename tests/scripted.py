"""Test doubles: a scripted skill, a flag guard and a physics-free context for the executor."""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np
from orchestrator.skills import SKILLS, Skill, SkillParams
from pydantic import Field

from orchestrator.engine.blackboard import Blackboard
from orchestrator.engine.context import Event
from orchestrator.guards.base import Guard, GuardParams, Violation


class ScriptedParams(SkillParams):
    outcome: str = Field(default="done", description="Outcome returned after `ticks` ticks.")
    ticks: int = Field(default=1, ge=1)
    script: list[str] | None = Field(
        default=None, description="Outcomes of successive entries (the last one repeats)."
    )
    key: str = "scripted_count"


class Scripted(Skill):
    """Returns a scripted outcome after a number of ticks; counts its entries."""

    name: ClassVar[str] = "scripted"
    Params: ClassVar[type[SkillParams]] = ScriptedParams
    outcomes: ClassVar[tuple[str, ...]] = ("done", "failed", "other")
    stopped: ClassVar[list[str]] = []

    params: ScriptedParams

    def start(self, ctx) -> None:
        count = ctx.blackboard.get(self.params.key, 0) or 0
        ctx.blackboard[self.params.key] = count + 1
        script = self.params.script
        self.outcome = script[min(count, len(script) - 1)] if script else self.params.outcome
        self.n = 0

    def step(self, ctx) -> str | None:
        self.n += 1
        return self.outcome if self.n >= self.params.ticks else None

    def stop(self, ctx) -> None:
        Scripted.stopped.append(f"{self.params.key}@{ctx.t:.2f}")


class FlagParams(GuardParams):
    flag: str = "danger"


class Flag(Guard):
    """Fires when the blackboard flag is true."""

    name: ClassVar[str] = "flag"
    Params: ClassVar[type[GuardParams]] = FlagParams
    params: FlagParams

    def check(self, ctx) -> Violation | None:
        if ctx.blackboard.get(self.params.flag):
            return Violation(self.name, f"{self.params.flag} is set", True, False)
        return None


class _Controller:
    def __init__(self) -> None:
        self.held: list[Any] = []
        self.q_d = np.zeros(7)

    def hold(self, q) -> None:
        self.held.append(np.asarray(q).copy())


class InstantStop:
    """A controlled stop that is over at once (there is no arm to stop)."""

    active = False
    stop_time_s = 0.0
    distance_m = 0.0

    def __init__(self) -> None:
        self.reasons: list[str] = []
        self.released = 0

    def step(self) -> None:
        pass

    @property
    def at_rest(self) -> bool:
        return True

    def start(self, reason: str, gentle: bool = False, brake: bool = True) -> None:
        self.reasons.append(reason)

    def release(self) -> None:
        self.released += 1

    def timed_out(self) -> bool:
        return False


class FakeContext:
    """Just what the executor and the test skills touch: time, blackboard, events."""

    def __init__(self, blackboard: dict | None = None, dt: float = 0.01) -> None:
        self.t = 0.0
        self.clock_offset = 0.0
        self.clock_rate = 1.0
        self.dt_control = dt
        self.blackboard = Blackboard(blackboard or {})
        self.events: list[Event] = []
        self.listeners: list = []
        self.controller = _Controller()
        self.q = np.zeros(7)
        self.qd = np.zeros(7)
        self.tcp_pos = np.zeros(3)
        self.metrics: dict = {}

    @property
    def clock(self) -> float:
        return self.t - self.clock_offset

    def log(self, kind: str, message: str, level: str = "INFO", **data: Any) -> None:
        self.events.append(Event(self.t, kind, message, level, data or None))


def register() -> None:
    """Make `scripted` and `flag` available to the loader, validator and executor."""
    from orchestrator.skills import skill_names

    from orchestrator.guards import GUARDS

    skill_names()
    SKILLS["scripted"] = Scripted
    GUARDS["flag"] = Flag
