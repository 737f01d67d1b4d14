"""A machine's inputs, and the values in it that become positions.

A live command or a planner's reply may set only a machine's *inputs*: blackboard keys the
machine declares as such (`input: true`), or, by default, its goal-like keys — those a motion's
`target`, a `via` point's target or a position hint (`near`) reads as `$key`, unless a skill
writes them (a value sent would be overwritten before it is read). Scenario values (guards,
physics, scene, robot) are never inputs: they are the scenario's, and change only with another
scenario.

Every value that becomes a position the arm goes to is a `PoseUse`: a motion's target plus its
offset (`move`'s `target` and `offset`, each `via` point's), or a position hint (a search
picks what is nearest it). The live guardrail checks every use a command's values take part in.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

from pydantic import BaseModel

from ..skills import find_skill
from .diagnostics import Diagnostic
from .goals import goal_keys, item_model
from .loading import MachineNode
from .refs import parse_ref
from .validation import blackboard_types, skill_writes

__all__ = ["PoseUse", "check_inputs", "hint_keys", "machine_inputs", "pose_uses", "writers"]

TARGET = "target"
"""Role of a motion's target (with its offset): the arm goes there."""
HINT = "hint"
"""Role of a position hint: what is nearest it is picked (the arm does not go to it)."""


@dataclass(frozen=True)
class PoseUse:
    """One place where blackboard values become a position.

    Attributes:
        where: The state and parameter, for messages (`TRANSPORT.via[0]`).
        role: `target` (a motion goes there) or `hint` (the nearest object is picked).
        target: The target or hint parameter as written (`$place_at`, a name, `[x, y, z]`).
        offset: The offset parameter as written (`$hover`, `[0, 0, 0.1]`), None if none.
        radius: For a hint: its radius as written (a number or `$key`) [m].
        object: For a hint: the object looked for, as written (None: any).
    """

    where: str
    role: str
    target: Any
    offset: Any = None
    radius: Any = None
    object: Any = None

    def keys(self) -> set[str]:
        """Blackboard keys the use reads whole (`$key`, not `$key.field`)."""
        out = set()
        for value in (self.target, self.offset, self.radius):
            ref = parse_ref(value)
            if ref is not None and not ref[1]:
                out.add(ref[0])
        return out


def _extra(info: Any) -> dict[str, Any]:
    extra = info.json_schema_extra
    return extra if isinstance(extra, dict) else {}


def _scan(model: type[BaseModel], params: dict, where: str) -> list[PoseUse]:
    out = []
    fields = model.model_fields
    for name, info in fields.items():
        key = info.alias or name
        value = params.get(key)
        nested = item_model(info.annotation)
        if nested is not None:  # `move`'s via points
            for i, item in enumerate(value if isinstance(value, list) else []):
                if isinstance(item, dict):
                    out += _scan(nested, item, f"{where}.{key}[{i}]")
            continue
        extra = _extra(info)
        if key not in params:
            continue
        if extra.get("scene_ref") == TARGET:
            offset = params.get("offset") if "offset" in fields else None
            out.append(PoseUse(f"{where}.{key}", TARGET, value, offset))
        elif extra.get("pose_role") == HINT:
            rfield = extra.get("radius")
            radius = params.get(rfield, fields[rfield].default) if rfield else None
            obj = params.get("object") if "object" in fields else None
            out.append(PoseUse(f"{where}.{key}", HINT, value, radius=radius, object=obj))
    return out


def pose_uses(machine: MachineNode) -> list[PoseUse]:
    """Every place in the tree where values become a position: each skill parameter marked as
    a target (`scene_ref: target`, with the `offset` beside it) or a position hint
    (`pose_role: hint`, with its radius), in `via` lists too."""
    out: list[PoseUse] = []
    for where, skill, params in _skill_states(machine):
        cls = find_skill(skill)
        if cls is not None:
            out += _scan(cls.Params, params, where)
    return out


def _skill_states(machine: MachineNode) -> Iterator[tuple[str, str, dict]]:
    """(dotted path, skill, `with:`) of every skill state and single-skill parallel branch."""
    for path, st, node in machine.walk():
        if st.skill:
            yield path, st.skill, st.with_
        for bname, branch in node.branches.get(path.rsplit(".", 1)[-1], {}).items():
            if not isinstance(branch, MachineNode) and branch.skill:
                yield f"{path}.{bname}", branch.skill, branch.with_


def hint_keys(machine: MachineNode) -> set[str]:
    """Keys read whole by a position hint (`search`'s `near`)."""
    return {
        ref[0]
        for use in pose_uses(machine)
        if use.role == HINT and (ref := parse_ref(use.target)) is not None and not ref[1]
    }


def writers(machine: MachineNode) -> dict[str, str]:
    """Blackboard key -> the first state (dotted path) whose skill writes it."""
    out: dict[str, str] = {}
    for where, skill, params in _skill_states(machine):
        for key in skill_writes(skill, params):
            out.setdefault(key, where)
    return out


def _flags(machine: MachineNode) -> tuple[set[str], dict[str, bool]]:
    """Declared keys, and the `input:` flags given (the outermost declaration wins)."""
    declared: set[str] = set()
    flags: dict[str, bool] = {}
    for node in reversed(list(machine.nodes())):  # the root last: outer levels win
        declared |= set(node.blackboard)
        flags.update(node.inputs)
    return declared, flags


def machine_inputs(machine: MachineNode) -> dict[str, str]:
    """The keys a live command or a planner may set, with their declared types."""
    declared, flags = _flags(machine)
    goal_like = goal_keys(machine) | hint_keys(machine)
    written = writers(machine)
    types = blackboard_types(machine)
    out = {}
    for key in sorted(declared):
        flag = flags.get(key)
        if flag is None:
            flag = key in goal_like and key not in written
        if flag:
            out[key] = types.get(key, "any")
    return out


def check_inputs(machine: MachineNode) -> list[Diagnostic]:
    """`input: true` on a key a skill writes (a value sent would be overwritten before it is
    read), and `recovery` below the top level, are errors."""
    out = []
    written = writers(machine)
    seen: set[int] = set()
    for node in machine.nodes():
        if id(node) in seen:
            continue
        seen.add(id(node))
        for key, flag in node.inputs.items():
            if flag and key in written:
                out.append(
                    node.source.diag(
                        (*node.at, "blackboard", key, "input"),
                        f"{key!r} is written by the skill of {written[key]}: a value sent "
                        "would be overwritten before it is read (to say where to look, give "
                        "the search a position hint, `near`)",
                    )
                )
        if node.recovery and not node.top:
            out.append(
                node.source.diag(
                    (*node.at, "recovery"),
                    "`recovery` takes effect only in the top-level machine (the one a run or "
                    "task starts): move it there",
                )
            )
    return out
