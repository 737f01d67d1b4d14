"""The Guard base: a safety condition checked every physics step, aborting from any state."""

from __future__ import annotations

import abc
from dataclasses import asdict, dataclass
from typing import TYPE_CHECKING, Any, ClassVar

from pydantic import BaseModel, ConfigDict

if TYPE_CHECKING:
    from ..engine.context import Context

__all__ = ["Guard", "GuardParams", "Violation"]


class GuardParams(BaseModel):
    """Base of every guard's `Params`: unknown keys are an error."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)


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


class Guard(abc.ABC):
    """A safety check. `bind` once per run (precompute indices), `check` every physics step.

    `check` runs 500 times per simulated second: keep it to a few array operations.
    """

    name: ClassVar[str]
    Params: ClassVar[type[GuardParams]]
    priority: ClassVar[int] = 0
    """Guards are checked in decreasing priority; the first violation wins."""

    def __init__(self, params: GuardParams) -> None:
        self.params = params

    def bind(self, ctx: Context) -> None:  # noqa: B027 - optional hook
        """Prepare for a run (look up indices, read limits from the model)."""

    def activate(self, ctx: Context) -> None:  # noqa: B027 - optional hook
        """The guard becomes active (its state or machine was entered): reset what it
        measures over time (a duration above a limit, a reference taken on entry)."""

    @abc.abstractmethod
    def check(self, ctx: Context) -> Violation | None:
        """None while safe, else the violation."""

    def monitored(self, ctx: Context) -> tuple[float, float] | None:
        """The scalar this guard watches and its limit, for plots (None if not scalar)."""
        return None
