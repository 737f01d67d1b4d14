"""Static checks of a loaded machine tree: everything that can be known before simulating."""

from __future__ import annotations

import re
from collections.abc import Iterable
from typing import Any

from pydantic import ValidationError

from ..guards import GUARDS
from ..skills import find_skill, get_skill, skill_names
from .blackboard_types import all_finite, check_type, sample_value
from .diagnostics import Diagnostic, closest, did_you_mean
from .loading import MachineNode, initial_values
from .machine import (
    BLACKBOARD_TYPES,
    BUILTIN_EVENTS,
    BranchSpec,
    GuardRef,
    StateSpec,
    guard_entries,
)
from .param_values import check_values, declared_at, pose_problem
from .pydantic_errors import diagnostics_from_validation
from .refs import has_ref, iter_refs, parse_ref, ref_type
from .yamlio import SourceMap

__all__ = [
    "RUN_OUTCOMES",
    "blackboard_keys",
    "blackboard_types",
    "branch_outcomes",
    "written_keys",
    "skill_writes",
    "state_outcomes",
    "validate_guards",
    "validate_machine",
]

POSE_FIELDS = ("pos", "quat")
_EVENT_NAME = re.compile(r"[a-z][a-z0-9_]*")


def skill_writes(skill: str, params: dict) -> dict[str, str]:
    """Blackboard key -> type that a skill state writes (from its `writes` declaration)."""
    cls = find_skill(skill)
    if cls is None:
        return {}
    writes = cls.writes if isinstance(cls.writes, dict) else dict.fromkeys(cls.writes, "any")
    out = {}
    for fld, type_ in writes.items():
        value = params.get(fld, cls.Params.model_fields[fld].default)
        if isinstance(value, str):
            out[value] = type_
    return out


def branch_outcomes(branch: MachineNode | BranchSpec) -> list[str]:
    """Outcomes a parallel branch can end with; the first one is its success."""
    if isinstance(branch, MachineNode):
        return branch.outcomes()
    cls = find_skill(branch.skill or "")
    out = list(cls.outcomes) if cls is not None else []
    if branch.timeout is not None and "timeout" not in out:
        out.append("timeout")
    return out


def state_outcomes(node: MachineNode, name: str) -> list[str]:
    """Outcomes the state `name` of `node` can end with; the first one is its success."""
    st = node.states[name]
    if st.skill is not None:
        cls = find_skill(st.skill)
        out = list(cls.outcomes) if cls is not None else []
    elif st.parallel is not None:
        if st.rule == "first":
            out = []
            for branch in node.branches.get(name, {}).values():
                out += [o for o in branch_outcomes(branch) if o not in out]
        else:
            out = ["succeeded", "failed"]
    elif name in node.children:
        out = node.children[name].outcomes()
    else:
        out = []
    if st.timeout is not None and "timeout" not in out:
        out.append("timeout")
    return out


def _skill_specs(node: MachineNode) -> Iterable[tuple[str, dict]]:
    for sub in node.nodes():
        for st in sub.states.values():
            if st.skill is not None:
                yield st.skill, st.with_
        for _, _, branch in sub.skill_branches():
            assert branch.skill is not None
            yield branch.skill, branch.with_


def blackboard_types(node: MachineNode) -> dict[str, str]:
    """Every key declared in the tree or written by one of its skills, with its type."""
    types: dict[str, str] = {}
    for sub in node.nodes():
        for key, type_ in skill_writes_of(sub).items():
            types.setdefault(key, type_)
    for sub in node.nodes():
        for key, type_ in sub.types.items():
            if type_ != "any" or key not in types:
                types[key] = type_
    return types


def skill_writes_of(sub: MachineNode) -> dict[str, str]:
    out: dict[str, str] = {}
    for st in sub.states.values():
        if st.skill is not None:
            out.update(skill_writes(st.skill, st.with_))
    for _, _, branch in sub.skill_branches():
        out.update(skill_writes(branch.skill or "", branch.with_))
    return out


def blackboard_keys(node: MachineNode) -> set[str]:
    """Keys declared anywhere in the tree or written by one of its skills."""
    return set(blackboard_types(node))


def validate_machine(node: MachineNode, extra_keys: Iterable[str] = ()) -> list[Diagnostic]:
    """Every static problem of `node` and its nested machines."""
    types = blackboard_types(node)
    for key in extra_keys:
        types.setdefault(key, "any")
    out = _check(node, types, set())
    if not out:  # the defaults, through the parameters that read them
        out += check_values(node, initial_values(node, {}), declared_at(node), written_keys(node))
    return out


def written_keys(node: MachineNode) -> set[str]:
    """Blackboard keys some skill of the tree writes."""
    return {key for sub in node.nodes() for key in skill_writes_of(sub)}


def _check(node: MachineNode, types: dict[str, str], seen: set[int]) -> list[Diagnostic]:
    if id(node) in seen:
        return []  # a machine included in several places is checked once
    seen.add(id(node))
    src, at = node.source, node.at
    out: list[Diagnostic] = []
    names = tuple(node.states)
    if node.initial not in node.states:
        out.append(_unknown_state(src, (*at, "initial"), node.initial, names))
    if node.on_abort is not None:
        if node.on_abort not in node.states:
            out.append(_unknown_state(src, (*at, "on_abort"), node.on_abort, names))
    out += _check_events(node)
    out += validate_guards(node.guards, src, (*at, "guards"))
    for key, value in node.blackboard.items():
        kat = (*at, "blackboard", key)
        type_ = node.types.get(key, "any")
        if type_ == "any":  # a short-form default: is it a typed declaration gone wrong?
            bad = _bad_declaration(value, src, kat)
            if bad is not None:
                out.append(bad)
                continue
        if not check_type(value, type_):
            out.append(src.diag(kat, f"default {value!r} is not a {type_}"))
        elif not all_finite(value):
            out.append(
                src.diag(kat, f"default {value!r} holds NaN or infinity: give finite numbers")
            )
        out += _check_refs(value, types, src, kat)
    writes = skill_writes_of(node)
    for key, type_ in writes.items():
        declared = types.get(key, "any")
        if declared not in ("any", type_) and type_ != "any":
            out.append(
                src.diag(
                    (*at, "blackboard"),
                    f"key {key!r} is declared {declared} but a skill writes a {type_} into it",
                )
            )
    for name, st in node.states.items():
        out += _check_state(node, name, st, types, names)
        if node.top and st.final is not None and st.final not in RUN_OUTCOMES:
            close = did_you_mean(st.final, RUN_OUTCOMES, cutoff=0.8)
            if close:
                out.append(
                    src.diag(
                        (*at, "states", name, "final"),
                        f"{st.final!r} is not an outcome of a run{close}: the top-level "
                        "machine's final states end the run `succeeded`, `failed` or `aborted` "
                        "(any other outcome ends it `failed`)",
                        RUN_OUTCOMES,
                    )
                )
    out += _check_graph(node)
    for child in node.children.values():
        out += _check(child, types, seen)
    for branches in node.branches.values():
        for branch in branches.values():
            if isinstance(branch, MachineNode):
                out += _check(branch, types, seen)
    return out


RUN_OUTCOMES = ("succeeded", "failed", "aborted")
"""The outcomes a run ends with; the top-level machine's `final:` values name them."""
_DECLARATION_KEYS = {"type", "default", "description"}


def _bad_declaration(value: Any, src: SourceMap, at: tuple) -> Diagnostic | None:
    """A short-form default that is a typed declaration gone wrong (`{type: strng, default:
    cube}`): the long form's keys only, but no valid `type`. Said as the declaration's
    mistake, not accepted as a mapping default that fails at run time."""
    if not isinstance(value, dict) or "type" not in value or not set(value) <= _DECLARATION_KEYS:
        return None
    type_ = value["type"]
    if type_ in BLACKBOARD_TYPES:
        return None
    return src.diag(
        (*at, "type"),
        f"unknown blackboard type {type_!r}{did_you_mean(type_, BLACKBOARD_TYPES)}: a "
        "mapping of `type`, `default` and `description` declares a typed key",
        BLACKBOARD_TYPES,
    )


def _check_events(node: MachineNode) -> list[Diagnostic]:
    """`events:` names states of this machine, never a built-in event, and only at the top
    (an event preempts the whole machine, like `on_abort`)."""
    src, at = node.source, (*node.at, "events")
    out = []
    if node.events and not node.top:
        out.append(
            src.diag(at, "`events` only take effect in the top-level machine: move them there")
        )
    for event, target in node.events.items():
        if event in BUILTIN_EVENTS:
            out.append(
                src.diag(
                    (*at, event),
                    f"{event!r} is a built-in event and cannot be mapped to a state"
                    f" (built in: {', '.join(BUILTIN_EVENTS)})",
                )
            )
        elif not _EVENT_NAME.fullmatch(str(event)):
            out.append(
                src.diag(
                    (*at, event),
                    f"event name {event!r} must be a lowercase identifier (e.g. stop, go_home)",
                )
            )
        if target not in node.states:
            out.append(_unknown_state(src, (*at, event), target, tuple(node.states)))
    return out


def _check_state(
    node: MachineNode, name: str, st: StateSpec, types: dict[str, str], names: tuple[str, ...]
) -> list[Diagnostic]:
    src = node.source
    sat = (*node.at, "states", name)
    out: list[Diagnostic] = []
    known = True
    if st.skill is not None:
        if find_skill(st.skill) is None:
            known = False
            out.append(_unknown_skill(src, (*sat, "skill"), st.skill))
        else:
            out += _check_params(st.skill, st.with_, types, src, (*sat, "with"))
    if st.parallel is not None:
        for bname, branch in node.branches.get(name, {}).items():
            if isinstance(branch, BranchSpec) and branch.skill is not None:
                bat = (*sat, "parallel", bname)
                if find_skill(branch.skill) is None:
                    known = False
                    out.append(_unknown_skill(src, (*bat, "skill"), branch.skill))
                else:
                    out += _check_params(branch.skill, branch.with_, types, src, (*bat, "with"))
        known = known and set(node.branches.get(name, {})) == set(st.parallel)
    if st.machine is not None and name not in node.children:
        known = False  # the include failed; reported by the loader
    outcomes = state_outcomes(node, name)
    if known and st.final is None:
        what = (
            f"skill {st.skill!r}"
            if st.skill
            else ("the parallel state" if st.parallel is not None else "the nested machine")
        )
        for outcome in st.transitions:
            if outcome not in outcomes:
                out.append(
                    src.diag(
                        (*sat, "transitions", outcome),
                        f"{what} has no outcome {outcome!r}",
                        tuple(outcomes),
                    )
                )
        for outcome in outcomes:
            if outcome not in st.transitions:
                out.append(
                    src.diag(
                        (*sat, "transitions") if st.transitions else sat,
                        f"outcome {outcome!r} is not handled: add `{outcome}: <STATE>` "
                        "to transitions",
                        names,
                    )
                )
        for outcome in st.retry_on or ():
            if outcome not in outcomes:
                out.append(src.diag((*sat, "retry_on"), f"no outcome {outcome!r}", tuple(outcomes)))
    for outcome, target in st.transitions.items():
        if target not in node.states:
            out.append(_unknown_target(node, (*sat, "transitions", outcome), target))
    out += validate_guards(st.guards, src, (*sat, "guards"))
    return out


def _check_graph(node: MachineNode) -> list[Diagnostic]:
    src, at = node.source, node.at
    states = node.states
    edges = {n: {t for t in st.transitions.values() if t in states} for n, st in states.items()}
    reachable: set[str] = set()
    todo = [s for s in (node.initial, node.on_abort, *node.events.values()) if s in states]
    while todo:
        s = todo.pop()
        if s not in reachable:
            reachable.add(s)
            todo.extend(edges[s])
    out = []
    if node.on_abort is not None and not node.top:
        out.append(
            src.diag(
                (*at, "on_abort"),
                "`on_abort` only takes effect in the top-level machine: move it there",
            )
        )
    # a transition to a misspelled state is reported once, as an unknown state: the states
    # it leaves unreached or stranded are consequences, not more mistakes to report
    dangling = any(t not in states for st in states.values() for t in st.transitions.values())
    for name in states:
        if name not in reachable and node.initial in states and not dangling:
            out.append(
                src.diag(
                    (*at, "states", name),
                    f"state {name!r} is unreachable from "
                    f"{node.initial!r}: no transition leads to it",
                )
            )
    finals = {n for n, st in states.items() if st.final is not None}
    # states that can finish: walk the edges backwards from the finals (linear in the edges)
    sources: dict[str, list[str]] = {n: [] for n in states}
    for n, targets in edges.items():
        for t in targets:
            sources[t].append(n)
    can_finish = set(finals)
    todo = list(finals)
    while todo:
        for n in sources[todo.pop()]:
            if n not in can_finish:
                can_finish.add(n)
                todo.append(n)
    if not finals:
        out.append(
            src.diag(
                (*at, "states"),
                "the machine has no final state (add e.g. `DONE: {final: succeeded}`)",
            )
        )
    elif not dangling:
        for name in states:
            if name in reachable and name not in can_finish:
                out.append(
                    src.diag((*at, "states", name), f"state {name!r} has no path to a final state")
                )
    return out


def _unknown_target(node: MachineNode, at: tuple, name: str) -> Diagnostic:
    """A transition to an undeclared state. When the declared state closest to it is one
    nothing leads to, the declaration is the likely typo (`FAILD: {final: failed}` beside
    transitions to FAILED): the message says to rename it rather than to retarget the
    transition to the misspelled name."""
    names = tuple(node.states)
    close = closest(name, names)
    targets = [t for st in node.states.values() for t in st.transitions.values()]
    reached = {*targets, node.initial, node.on_abort, *node.events.values()}
    if close is None or close in reached:
        return _unknown_state(node.source, at, name, names)
    rename = f"rename the declaration {close!r} to {name!r}"
    if targets.count(name) >= 2:  # several transitions agree: the declaration is the typo
        message = (
            f"unknown state {name!r}: {targets.count(name)} transitions lead to it but none is "
            f"declared, and the declared {close!r} is reached by no transition: {rename}"
        )
    else:
        message = (
            f"unknown state {name!r} (did you mean {close!r}?); if the declaration is the "
            f"typo, {rename}"
        )
    return node.source.diag(at, message, names)


def _unknown_state(src: SourceMap, at: tuple, name: str, names: tuple[str, ...]) -> Diagnostic:
    return src.diag(at, f"unknown state {name!r}{did_you_mean(name, names)}", names)


def _unknown_skill(src: SourceMap, at: tuple, name: str) -> Diagnostic:
    names = tuple(skill_names())
    return src.diag(at, f"unknown skill {name!r}{did_you_mean(name, names)}", names)


_QUAT_SAMPLE = [1.0, 0.0, 0.0, 0.0]


def _sample(type_: str | None) -> Any:
    return _QUAT_SAMPLE if type_ == "quat" else sample_value(type_ or "any")


def _check_refs(value: Any, types: dict[str, str], src: SourceMap, path: tuple) -> list[Diagnostic]:
    out = []
    for p, key, rest in iter_refs(value, path):
        if key.startswith("$"):
            out.append(
                src.diag(p, f"malformed reference {key!r}: use `$key`, `$key.field` or `$key[0]`")
            )
        elif key not in types:
            valid = tuple(sorted(types))
            out.append(
                src.diag(
                    p,
                    f"`${key}` reads a blackboard key that is never declared or "
                    f"written{did_you_mean(key, valid)}: declare it under `blackboard:`",
                    valid,
                )
            )
        elif rest:
            _, problem = ref_type(types[key], rest, key)
            if problem is not None:
                valid = POSE_FIELDS if "is a pose: read" in problem else ()
                out.append(src.diag(p, problem, valid))
    return out


def _substitute(value: Any, types: dict[str, str]) -> Any:
    """Replace whole-value `$key` references by a sample of the type they read (None if it
    cannot be known)."""
    ref = parse_ref(value)
    if ref is not None:
        key, rest = ref
        type_, problem = ref_type(types.get(key, "any"), rest, key)
        return None if problem is not None else _sample(type_)
    if isinstance(value, dict):
        return {k: _substitute(v, types) for k, v in value.items()}
    if isinstance(value, list):
        return [_substitute(v, types) for v in value]
    return value


def _check_params(
    skill: str, params: dict, types: dict[str, str], src: SourceMap, path: tuple
) -> list[Diagnostic]:
    cls = get_skill(skill)
    out = _check_refs(params, types, src, path)
    concrete = {}
    unknown_refs = set()
    for k, v in params.items():
        if not has_ref(v):
            concrete[k] = v
            continue
        sub = _substitute(v, types)
        if k not in cls.Params.model_fields and not any(
            f.alias == k for f in cls.Params.model_fields.values()
        ):
            concrete[k] = v  # not a parameter of the skill: said so (with the closest one)
        elif sub is None or (isinstance(sub, (list, dict)) and _contains_none(sub)):
            unknown_refs.add(k)  # untyped reference: checked when the state starts
        else:
            concrete[k] = sub
    for name, info in cls.Params.model_fields.items():
        extra = info.json_schema_extra
        value = params.get(info.alias or name)
        if isinstance(extra, dict) and extra.get("scene_ref") == "target":
            if isinstance(value, (list, dict)) and not has_ref(value):
                problem = pose_problem(value)
                if problem is not None:
                    out.append(src.diag((*path, info.alias or name), f"{value!r} is {problem}"))
    try:
        cls.Params.model_validate(concrete)
    except ValidationError as exc:
        for d in diagnostics_from_validation(exc, cls.Params, src, params, path):
            leaf = d.path.split(".")[-1].split("[")[0]
            if "missing required key" in d.message and leaf in unknown_refs:
                continue
            if d.message.startswith("unknown key"):
                out.append(d)
                continue
            ref = parse_ref(params.get(leaf))
            if ref is not None and any(m in d.message for m in _RANGE_MESSAGES):
                continue  # the sample of the key's type is out of range, not the key's value
            if ref is not None:  # a typed `$key` whose type does not fit the parameter
                declared, _ = ref_type(types.get(ref[0], "any"), ref[1], ref[0])
                out.append(
                    src.diag(
                        (*path, leaf),
                        f"`{params[leaf]}` is a {declared}, which does not "
                        f"fit this parameter: {d.message.split(', got ')[0]}",
                        d.valid,
                    )
                )
            else:
                out.append(d)
    return out


_RANGE_MESSAGES = (
    "Input should be greater than",
    "Input should be less than",
    "should have at least",
    "should have at most",
)
"""How pydantic's range and length errors read: a `$key` of the right type is
checked against the parameter's range (a list's length) when the state starts, with its value."""


def _contains_none(value: Any) -> bool:
    if value is None:
        return True
    if isinstance(value, dict):
        return any(_contains_none(v) for v in value.values())
    if isinstance(value, list):
        return any(_contains_none(v) for v in value)
    return False


def validate_guards(refs: list[GuardRef] | dict, src: SourceMap, path: tuple) -> list[Diagnostic]:
    """Unknown guards and bad guard parameters."""
    out = []
    for pos, name, params in guard_entries(refs):
        gpath = (*path, pos)
        if name not in GUARDS:
            valid = tuple(sorted(GUARDS))
            out.append(src.diag(gpath, f"unknown guard {name!r}{did_you_mean(name, valid)}", valid))
            continue
        ppath = (*gpath, name) if isinstance(pos, int) else gpath
        if not isinstance(params, dict):
            out.append(
                src.diag(
                    ppath,
                    f"guard parameters must be a mapping, got {params!r}",
                    tuple(GUARDS[name].Params.model_fields),
                )
            )
            continue
        try:
            GUARDS[name].Params.model_validate(params)
        except ValidationError as exc:
            out += diagnostics_from_validation(exc, GUARDS[name].Params, src, params, ppath)
    return out
