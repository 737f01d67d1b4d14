"""The machine language as pydantic models (the YAML keys are a contract: see
docs/machine-language.md)."""

from __future__ import annotations

from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, NonNegativeInt, PositiveFloat, model_validator

__all__ = [
    "ABORT",
    "BUILTIN_EVENTS",
    "ESTOP",
    "PAUSE",
    "RESUME",
    "SAFE_STOP",
    "BLACKBOARD_TYPES",
    "BlackboardKey",
    "BranchSpec",
    "GuardRef",
    "MachineSpec",
    "StateSpec",
    "guard_entries",
]

ABORT = "abort"
"""The trigger of the transition a guard violation fires from any state."""
SAFE_STOP = "SAFE_STOP"
"""The built-in state of the controlled stop every abort goes through first."""
ESTOP = "estop"
"""The emergency stop: a built-in event of every machine and the reason's guard name."""
PAUSE = "pause"
"""Built-in event: every active skill freezes, the arm holds, skill clocks and timeouts stop."""
RESUME = "resume"
"""Built-in event: the paused states continue where they were."""
BUILTIN_EVENTS = (ESTOP, PAUSE, RESUME)
"""Events every machine has; none of them can be mapped to a state."""

BLACKBOARD_TYPES = ("any", "str", "int", "float", "bool", "vec3", "pose", "list", "dict")
BlackboardType = Literal["any", "str", "int", "float", "bool", "vec3", "pose", "list", "dict"]

GuardRef = str | dict[str, dict[str, Any] | None]
"""A guard by name (`joint_limits`) or with parameters (`{contact_force: {max_n: 40}}`)."""


def guard_entries(refs: list[GuardRef] | dict[str, Any]) -> list[tuple[int | str, str, Any]]:
    """Normalize guard references to `(position, name, params)`.

    Accepts the list form of machines and the mapping form (`{name: params}`) of scenarios.
    """
    out: list[tuple[int | str, str, Any]] = []
    if isinstance(refs, dict):
        for name, params in refs.items():
            out.append((name, str(name), {} if params is None else params))
        return out
    for i, ref in enumerate(refs):
        if isinstance(ref, dict):
            for name, params in ref.items():
                out.append((i, str(name), {} if params is None else params))
        else:
            out.append((i, str(ref), {}))
    return out


class _Strict(BaseModel):
    # `StateSpec` names itself, and `BranchSpec` names it before it is defined: pydantic
    # resolves both when `MachineSpec` first validates (no `model_rebuild()` at import, which
    # would build two more validators that loading a machine never uses)
    model_config = ConfigDict(
        defer_build=True, extra="forbid", populate_by_name=True, allow_inf_nan=False
    )


class BlackboardKey(_Strict):
    """A typed blackboard declaration: `hover: {type: vec3, default: [0, 0, 0.1]}`.

    The short form `hover: [0, 0, 0.1]` declares a key with that default and a type inferred
    from it (`null` declares a key of type `any` with no value yet).
    """

    type: BlackboardType = Field(description="Value type; checked for defaults and overrides.")
    default: Any = Field(default=None, description="Initial value (null: none yet).")
    description: str | None = None
    input: bool | None = Field(
        default=None,
        description="A live command or a planner may set this key (`send run --set`, `ask`). "
        "Default: true for a goal-like key (one a motion's `target`, a `via` point's target or "
        "a position hint `near` reads) that no skill writes, false for any other. Scenario "
        "values (guards, physics, scene, robot) are never inputs.",
    )


class BranchSpec(_Strict):
    """One branch of a parallel state: a skill, a nested machine file, or inline states."""

    description: str | None = None
    skill: str | None = None
    with_: dict[str, Any] = Field(default_factory=dict, alias="with")
    machine: str | None = None
    initial: str | None = None
    states: dict[str, StateSpec] | None = None
    timeout: PositiveFloat | None = Field(
        default=None, description="Simulated seconds before the branch ends with `timeout`."
    )

    @model_validator(mode="after")
    def _one_kind(self) -> BranchSpec:
        kinds = [k for k in ("skill", "machine", "states") if getattr(self, k) is not None]
        if len(kinds) != 1:
            got = ", ".join(kinds) if kinds else "none of them"
            raise ValueError(
                f"a branch needs exactly one of `skill`, `machine` or `states` (got {got})"
            )
        if self.states is not None and self.initial is None:
            raise ValueError("inline `states` need an `initial` state")
        return self


class StateSpec(_Strict):
    """One state. It runs exactly one of: a `skill`, a nested `machine` file, inline `states`,
    or it is `final`.
    """

    description: str | None = None
    skill: str | None = Field(default=None, description="Skill to run, by its registered name.")
    with_: dict[str, Any] = Field(
        default_factory=dict,
        alias="with",
        description="Skill parameters; `$key` reads the blackboard.",
    )
    machine: str | None = Field(
        default=None,
        description="Nested machine file (relative to this file, then a bundled name).",
    )
    initial: str | None = Field(default=None, description="Initial state of inline `states`.")
    states: dict[str, StateSpec] | None = Field(default=None, description="Inline nested machine.")
    parallel: dict[str, BranchSpec] | None = Field(
        default=None, description="Named branches run side by side (see `rule`)."
    )
    rule: Literal["all", "any", "first"] = Field(
        default="all",
        description="Outcome of a parallel state: `all` succeed, `any` succeeds, or the "
        "`first` branch to finish decides (its outcome becomes the state's).",
    )
    final: str | None = Field(
        default=None, description="Final state: the outcome this machine ends with."
    )
    timeout: PositiveFloat | None = Field(
        default=None, description="Simulated seconds before the state ends with outcome `timeout`."
    )
    retry: NonNegativeInt = Field(
        default=0, le=10_000, description="Re-enter the state up to N times on a failure outcome."
    )
    retry_on: list[str] | None = Field(
        default=None,
        description="Outcomes that count as failures for `retry` (default: all but the first).",
    )
    transitions: dict[str, str] = Field(default_factory=dict, description="Outcome -> next state.")
    guards: list[GuardRef] = Field(
        default_factory=list, description="Guards active only while this state is active."
    )

    @model_validator(mode="after")
    def _one_kind(self) -> StateSpec:
        kinds = [
            k
            for k, v in (
                ("skill", self.skill),
                ("machine", self.machine),
                ("states", self.states),
                ("parallel", self.parallel),
                ("final", self.final),
            )
            if v is not None
        ]
        if len(kinds) != 1:
            got = ", ".join(kinds) if kinds else "none of them"
            raise ValueError(
                "a state needs exactly one of `skill`, `machine`, `states`, `parallel` or"
                f" `final` (got {got})"
            )
        if self.parallel is not None and not self.parallel:
            raise ValueError("`parallel` needs at least one branch")
        if self.states is not None and self.initial is None:
            raise ValueError("inline `states` need an `initial` state")
        if self.final is not None and self.transitions:
            raise ValueError("a `final` state has no `transitions`")
        return self

    @property
    def kind(self) -> str:
        if self.skill is not None:
            return "skill"
        if self.machine is not None:
            return "machine"
        if self.states is not None:
            return "states"
        if self.parallel is not None:
            return "parallel"
        return "final"


class MachineSpec(_Strict):
    """A state machine: states, the initial one, blackboard defaults and guards."""

    name: str
    description: str | None = None
    initial: str
    blackboard: dict[str, BlackboardKey | Any] = Field(
        default_factory=dict,
        description="Blackboard keys: `key: default` or `key: {type: ..., default: ...}`.",
    )
    guards: list[GuardRef] = Field(
        default_factory=list, description="Guards active while this machine runs."
    )
    on_abort: str | None = Field(
        default=None,
        description="State entered when a guard fires (default: the built-in safe stop).",
    )
    events: dict[str, str] = Field(
        default_factory=dict,
        description="Event name -> state entered when the event arrives, preempting whatever "
        "state is active (top-level machine only). Built in: estop, pause, resume.",
    )
    recovery: bool = Field(
        default=False,
        description="A recovery machine (top-level only): it may start where the world "
        "violates a guard; every guard stays active, and one already violated when it becomes "
        "active checks that its violation does not grow until it is within its limit again "
        "(the bundled `recover`).",
    )
    states: dict[str, StateSpec] = Field(min_length=1)
