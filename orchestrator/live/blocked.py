"""BLOCKED: the world violates a guard before a task can start.

An abort can leave the arm where a guard is violated — the hand resting on the cube
(`collision`), the TCP past the workspace box (`workspace`) — and every task would then abort
on its first physics step while the session looked IDLE. So while no task runs, the session
checks on the idle world, every control tick, the guards every task starts with (the
scenario's and `joint_limits`): the first one violated, in priority order, makes the state
BLOCKED and is published with its message, value and limit. Only a recovery machine (the
bundled `recover`, `recovery: true`) may start then; it backs the arm out with every guard
active (guards/easing.py).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from ..engine.episode import make_guards

if TYPE_CHECKING:
    from ..engine.context import Context
    from ..guards.base import Guard, Violation
    from ..language.load import LoadedScenario

__all__ = ["Blocked"]


class Blocked:
    """The guards a task starts with, checked on the idle world.

    Args:
        loaded: The session's scenario (its guards).
        ctx: The session's context (the guards are bound to it once).

    Attributes:
        violation: The first guard the idle world violates (None: none, or a task runs).
        recoverable: Moving the arm can undo it (the guard measures its `excess`).
    """

    def __init__(self, loaded: LoadedScenario, ctx: Context) -> None:
        guards = make_guards(loaded.scenario.guards, ctx) + make_guards(["joint_limits"], ctx)
        self.guards: list[Guard] = sorted(guards, key=lambda g: -g.priority)
        self.violation: Violation | None = None
        self.recoverable = True
        self._active = False

    def check(self, ctx: Context) -> Violation | None:
        """Check the guards on the idle world (once a control tick while no task runs)."""
        if not self._active:  # idle again: what they measure over time starts afresh
            for guard in self.guards:
                guard.activate(ctx)
            self._active = True
        for guard in self.guards:
            violation = guard.check(ctx)
            if violation is not None:
                self.violation, self.recoverable = violation, guard.excess(ctx) is not None
                return violation
        self.violation = None
        return None

    def task_started(self) -> None:
        """A task runs: its own guards watch the world until it ends."""
        self.violation, self._active = None, False

    def why(self) -> str:
        """The violation in words, for a refusal: `collision: robot contact with ...`."""
        v = self.violation
        return "" if v is None else f"{v.guard}: {v.message}"

    def to_dict(self) -> dict[str, Any] | None:
        """The status message's `blocked`: the guard, its message, value, limit and whether
        `recover` can undo it (None while not blocked)."""
        if self.violation is None:
            return None
        return {**self.violation.to_dict(), "recoverable": self.recoverable}
