"""The SuccessCheck base: a criterion judged once at the end of a run, with what it measured.

A check is a small class, registered by its `kind` like a skill by its `name` (bundled in this
package, from an installed plugin's `orchestrator.success_checks` entry points, or from a
folder of your own modules: a scenario's `skills:` or `--skills`). Its `Params` validate the
scenario's entry statically (`success: {placed: {kind: object_at, object: cube, ...}}`);
`evaluate` reads the finished episode through the same `Context` the skills had.
"""

from __future__ import annotations

import abc
from typing import TYPE_CHECKING, Any, ClassVar, NamedTuple

from ..skills.base import SCENE_OBJECT, SCENE_TARGET
from ..skills.plain_state import plain_state, restore_plain
from .params import CheckParams, Vec3

if TYPE_CHECKING:
    from ..engine.context import Context

__all__ = ["SCENE_OBJECT", "SCENE_TARGET", "CheckParams", "SuccessCheck", "Vec3", "Verdict"]


class Verdict(NamedTuple):
    """A check's judgement: passed, and what it measured against which limit (one line with
    the figures, e.g. `cube 0.4 mm from [0.5, 0.2], tilted 0.0 deg`)."""

    passed: bool
    detail: str


class SuccessCheck(abc.ABC):
    """One kind of success criterion.

    The framework builds it from the scenario's validated entry and calls `evaluate` once,
    after the machine has finished and the scene has settled (0.2 s after the arm came to
    rest). A failing check makes a succeeded run `failed`; its `detail` goes into the result's
    `success_detail`.

    Class attributes:
        kind: The name used in a scenario (`kind: stacked`).
        Params: Validates the scenario's entry (a `CheckParams` subclass).
    """

    kind: ClassVar[str]
    """The name used in a scenario (`kind: stacked`); unique among the checks of a process."""
    Params: ClassVar[type[CheckParams]]
    """Validates the scenario's entry (a `CheckParams` subclass; `kind` comes with it)."""

    def __init__(self, params: CheckParams) -> None:
        self.params = params
        """The scenario's entry, validated by `Params`."""

    @abc.abstractmethod
    def evaluate(self, ctx: Context) -> Verdict:
        """Judge the finished episode: ground truth (`ctx.object_pose`, `ctx.data`) is fair
        here — a success check is the experimenter's measurement, not the robot's."""

    def snapshot_state(self) -> dict[str, Any]:
        """What this check holds during a run, as plain data (skills/plain_state.py): a
        snapshot records it, and a resumed run must hold the same (docs/time-travel.md).
        Default: every attribute that is plain data (its validated `params` as their dump)."""
        return plain_state(self)

    def restore_state(self, data: dict[str, Any]) -> None:
        """Take back what `snapshot_state` recorded: a resumed run makes this check from its
        recorded parameters (its constructor runs, `start` does not) and hands it the data
        (docs/skill-api.md). Default: `restore_plain(self, data)`, each plain attribute set
        back (an array into the one already there). Override it with `snapshot_state` when
        the check holds objects of its own: rebuild them from the data you recorded."""
        restore_plain(self, data)

    def metrics(self, ctx: Context) -> dict[str, float]:
        """Figures for the result's `metrics`, each key prefixed with the check's name
        (`{"xy_error_mm": 0.4}` -> `cube_on_target_xy_error_mm`). Default: none."""
        return {}
