"""Guards while recovering: every guard stays active; one already violated watches that its
violation shrinks.

After an abort the world may be left violating a guard: the hand resting on the cube
(`collision`), pressing it (`contact_force`), the TCP past the workspace box (`workspace`).
Every task would then abort on its first physics step. A *recovery machine*
(`recovery: true`, the bundled `recover`) runs with each of its guards wrapped in `Eased`:

* a guard within its limits when it becomes active is checked as usual, from then on;
* a guard violated when it becomes active, that can measure how far past its limits it is
  (`Guard.excess`), instead fires when that grows: a limit it was past may not be exceeded by
  more than the least it has reached plus `ease_tolerance` (a ratchet: only motion that reduces
  the violation is allowed), a limit it was within may not be crossed. Once its own `check`
  passes again, it is checked as usual for the rest of the run.
* a guard violated when it becomes active that cannot measure it (`excess` is None: a sensor
  fault) is checked as usual: the recovery aborts on its first step, as any task would.

No guard is removed or loosened to get out: the envelope a recovery may move in is the one it
started in, shrinking as it gets out.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from .base import Envelope, Guard, Violation

if TYPE_CHECKING:
    from ..engine.context import Context

__all__ = ["Eased"]


class Eased(Guard):
    """`guard`, for a recovery machine (see the module docstring).

    Args:
        guard: The guard, bound to the run.

    Attributes:
        eased: The guard was violated when it became active and is not within its limits yet.
        start: Its excess when it became active (None if it was within). Shape as `excess`.
        best: The least excess reached so far, per limit.
    """

    def __init__(self, guard: Guard) -> None:
        super().__init__(guard.params)
        self.guard = guard
        self.name = guard.name  # type: ignore[misc]
        self.priority = guard.priority  # type: ignore[misc]
        self.eased = False
        self.start: np.ndarray | None = None
        self.best: np.ndarray | None = None

    def bind(self, ctx: Context) -> None:
        self.guard.bind(ctx)

    def activate(self, ctx: Context) -> None:
        self.guard.activate(ctx)
        excess = self.guard.excess(ctx)
        self.eased = excess is not None and bool(np.any(excess > 0.0))
        self.start = excess if self.eased else None
        self.best = None if excess is None else excess.copy()
        if self.eased:
            ctx.log("guard", f"{self.name}: violated on entry; recovering, it may only shrink")

    def check(self, ctx: Context) -> Violation | None:
        violation = self.guard.check(ctx)
        if not self.eased or violation is None:
            self.eased = self.eased and violation is not None  # within again: as usual
            return violation
        assert self.start is not None and self.best is not None
        excess = self.guard.excess(ctx)
        assert excess is not None
        tol = self.guard.ease_tolerance
        bound = np.where(self.start > 0.0, self.best + tol, 0.0)
        over = np.flatnonzero(~(excess <= bound))  # NaN is never within
        if not len(over):
            np.minimum(self.best, excess, out=self.best)
            return None
        i = int(over[0])
        unit = self.guard.ease_unit
        if self.start[i] > 0.0:
            why = (
                f"grew while recovering: {excess[i]:.4g} {unit} past its limit, the least it had "
                f"reached was {self.best[i]:.4g} {unit} (tolerance {tol:g} {unit})"
            )
        else:
            why = "a new violation while recovering"
        return Violation(
            self.name,
            f"{violation.message} ({why})",
            violation.value,
            violation.limit,
        )

    def envelope(self, ctx: Context) -> Envelope | None:
        return None if self.eased else self.guard.envelope(ctx)

    def settled(self) -> bool:
        return self.guard.settled()

    def monitored(self, ctx: Context) -> tuple[float, float] | None:
        return self.guard.monitored(ctx)

    def excess(self, ctx: Context) -> np.ndarray | None:
        return self.guard.excess(ctx)
