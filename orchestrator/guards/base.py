"""The Guard base: a safety condition checked every physics step, aborting from any state."""

from __future__ import annotations

import abc
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np
from pydantic import BaseModel, ConfigDict

if TYPE_CHECKING:
    from ..engine.context import Context

__all__ = ["Envelope", "Guard", "GuardParams", "Violation"]


class GuardParams(BaseModel):
    """Base of every guard's `Params`: unknown keys are an error. Its validator is built on
    first use (`defer_build`): a command loads every guard's `Params` and uses few."""

    model_config = ConfigDict(defer_build=True, extra="forbid", allow_inf_nan=False)


@dataclass(frozen=True)
class Violation:
    """A guard fired.

    Attributes:
        guard: The guard's name.
        message: What was violated, in words.
        value: The measured value that crossed the limit.
        limit: The limit it crossed.
    """

    guard: str
    message: str
    value: Any
    limit: Any

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


@dataclass(frozen=True)
class Envelope:
    """Where a guard's `check` certainly returns None (and leaves its state as it is).

    Attributes:
        bounds: `(view, lo, hi)`: every element of the 1-D `view` (a view bound once, read
            every step) satisfies `lo[i] <= view[i] <= hi[i]` (lo, hi: shape (len(view),)).
            NaN is never inside.
        equal: `(a, b)`: the two 1-D views read equal, element for element.
        scalars: `(read, hi)`: `read() <= hi` (`read` is called every step: a cached reading
            such as `Context.wrist_force_norm_sq`).
        stateful: The guard keeps state across steps that only its `check` updates (a
            duration above a limit): after any step it was checked in full, it is checked in
            full again until `Guard.settled` says its state is at rest.
    """

    bounds: tuple[tuple[np.ndarray, Sequence[float], Sequence[float]], ...] = ()
    equal: tuple[tuple[np.ndarray, np.ndarray], ...] = ()
    scalars: tuple[tuple[Callable[[], float], float], ...] = ()
    stateful: bool = False


class Guard(abc.ABC):
    """A safety check. `bind` once per run (precompute indices), `check` every physics step.

    `check` runs 500 times per simulated second: keep it to a few array operations.
    """

    name: ClassVar[str]
    Params: ClassVar[type[GuardParams]]
    priority: ClassVar[int] = 0
    """Guards are checked in decreasing priority; the first violation wins."""
    ease_tolerance: ClassVar[float] = 0.0
    """While recovering (guards/easing.py): how much a violation may grow beyond the least it
    has reached before the guard fires, in the unit of `excess` (the readings' noise)."""
    ease_unit: ClassVar[str] = ""
    """The unit of `excess` (for messages)."""

    def __init__(self, params: GuardParams) -> None:
        self.params = params

    @classmethod
    def robot_problems(cls, params: GuardParams, robot: type) -> list[tuple[str, str]]:
        """What the robot class `robot` cannot take of `params`, as (key, message) pairs: a
        per-joint list of the wrong length, a limit above its datasheet. Checked when a
        scenario is loaded (reported with its file and line, exit 2) and again by `bind`.
        None by default."""
        return []

    def bind(self, ctx: Context) -> None:  # noqa: B027 - optional hook
        """Prepare for a run (look up indices, read limits from the model)."""

    def activate(self, ctx: Context) -> None:  # noqa: B027 - optional hook
        """The guard becomes active (its state or machine was entered): reset what it
        measures over time (a duration above a limit, a reference taken on entry)."""

    @abc.abstractmethod
    def check(self, ctx: Context) -> Violation | None:
        """None while safe, else the violation."""

    def envelope(self, ctx: Context) -> Envelope | None:
        """Bounds on the readings `check` watches inside which it certainly returns None and
        changes nothing (guards/bank.py): the physics step then tests all guards' bounds
        at once and runs `check` only when a value leaves them. Called when the set of active
        guards changes (after `activate`). None (the default): `check` runs every step."""
        return None

    def settled(self) -> bool:
        """For a guard with a stateful envelope: its state is at rest (nothing counting), so
        an envelope test may stand in for `check` again."""
        return True

    def monitored(self, ctx: Context) -> tuple[float, float] | None:
        """The scalar this guard watches and its limit, for plots (None if not scalar)."""
        return None

    def excess(self, ctx: Context) -> np.ndarray | None:
        """How far past each of its limits the readings are now, one value per limit, in
        `ease_unit` (> 0: past it by that much; <= 0: within it). Moving the arm can reduce
        it: while recovering, a violated guard checks that its excess does not grow
        (guards/easing.py). None (the default): the guard cannot say — a violation of it
        (a sensor fault, a count over time) is not one motion can undo."""
        return None
