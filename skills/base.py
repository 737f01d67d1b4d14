"""The Skill base: an atomic, non-blocking robot behaviour with a py_trees-style lifecycle."""

from __future__ import annotations

import abc
from typing import TYPE_CHECKING, Any, ClassVar

from pydantic import BaseModel, ConfigDict

from .plain_state import plain_state, restore_plain

if TYPE_CHECKING:
    from orchestrator.engine.context import Context

__all__ = ["GRIPPED_OBJECT", "SCENE_OBJECT", "SCENE_TARGET", "Skill", "SkillParams"]

SCENE_OBJECT = {"scene_ref": "object"}
"""`json_schema_extra` of a parameter naming a scene object: checked against the scenario."""
GRIPPED_OBJECT = {"scene_ref": "gripped_object"}
"""`json_schema_extra` of a parameter naming the object a gripper holds: a scene object, or
`*` for whichever one the fingers press on (parcels drawn per seed have no name to give)."""
SCENE_TARGET = {"scene_ref": "target"}
"""`json_schema_extra` of a parameter that, when it is a name, names an object or a marker."""


class SkillParams(BaseModel):
    """Base of every skill's `Params` (a pydantic model): unknown keys are an error, naming the
    valid ones; NaN and infinity are refused. A field's `description` ending in a unit
    (`"How long to hold [s]."`) gives the unit column of `orchestrator show skill`; a
    `json_schema_extra` of `SCENE_OBJECT`, `GRIPPED_OBJECT` or `SCENE_TARGET` makes the
    validator check the name against the scenario before anything moves."""

    # the validator is built on first use: a command loads every skill's Params and uses few
    model_config = ConfigDict(
        defer_build=True, extra="forbid", arbitrary_types_allowed=True, allow_inf_nan=False
    )


class Skill(abc.ABC):
    """One atomic behaviour run by a state.

    The framework owns the loop: `start` once on entry, `step` every control tick until it
    returns an outcome, `stop` on exit (also when a guard aborts or a timeout fires). A skill
    never blocks and never steps physics itself.

    Class attributes:
        name: The name used in YAML (`skill: move`).
        Params: Validates the state's `with:` block.
        outcomes: Every outcome `step` can return; the first one is the success outcome.
        writes: Params field holding a blackboard key this skill writes -> the type it writes
            (`{"into": "pose"}`); a tuple of field names means type `any`.
    """

    name: ClassVar[str]
    """The name used in YAML (`skill: move`); unique among the skills of a process."""
    Params: ClassVar[type[SkillParams]]
    """Validates the state's `with:` block (a `SkillParams` subclass)."""
    outcomes: ClassVar[tuple[str, ...]]
    """Every outcome `step` can return; the first one is the success outcome."""
    explained: ClassVar[tuple[str, ...]] = ()
    """Outcomes besides the failure ones whose transition carries `explain`'s text as its
    `detail` (a monitor's only outcome: `watch_force`'s `contact`, with the force felt)."""
    writes: ClassVar[dict[str, str] | tuple[str, ...]] = {}
    """Params field holding a blackboard key this skill writes -> the type it writes
    (`{"into": "pose"}`); a tuple of field names means type `any`."""
    needs_scene: ClassVar[tuple[str, ...]] = ()
    """Keys of `scene` the skill cannot run without (e.g. `conveyor`): a scenario whose scene
    lacks one is an error naming the state, before anything moves."""

    def __init__(self, params: SkillParams) -> None:
        self.params = params
        """The state's `with:` block, validated by `Params` (blackboard reads resolved when
        the state was entered)."""

    def start(self, ctx: Context) -> None:  # noqa: B027 - optional hook
        """Capture the start state and set targets."""

    @abc.abstractmethod
    def step(self, ctx: Context) -> str | None:
        """Advance one control tick: None while running, else one of `outcomes`."""

    def stop(self, ctx: Context) -> None:
        """Leave a safe setpoint behind: by default hold the current joint angles."""
        ctx.controller.hold(ctx.q)

    def explain(self, ctx: Context) -> str | None:
        """Why the skill ended other than with its first outcome, or what it was still
        waiting for when its state's `timeout:` cut it off (one sentence, with the figures).

        Called just before `stop` when a skill ends with a failure outcome or is timed out;
        the text goes into that transition's `detail` in the result. Default: nothing to say.
        """
        return None

    def snapshot_state(self) -> dict[str, Any]:
        """What this skill holds mid-motion, as plain data (skills/plain_state.py): a snapshot
        records it, and a resumed run, rebuilt from the scenario, must hold the same before it
        goes on (docs/time-travel.md). Default: every attribute that is plain data. Override it
        to leave out a cache or to add what an object of your own holds."""
        return plain_state(self)

    def restore_state(self, data: dict[str, Any]) -> None:
        """Take back what `snapshot_state` recorded: a resumed run makes this skill from its
        recorded parameters (its constructor runs, `start` does not) and hands it the data
        (docs/skill-api.md). Default: `restore_plain(self, data)`, each plain attribute set
        back (an array into the one already there). Override it with `snapshot_state` when
        the skill holds objects of its own: rebuild them from the data you recorded."""
        restore_plain(self, data)

    def written_keys(self) -> list[str]:
        """Blackboard keys this instance writes (the values of its `writes` fields)."""
        return [getattr(self.params, f) for f in self.writes]  # dict iterates its fields
