"""Static checks of a loaded machine tree: everything that can be known before simulating."""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

from pydantic import ValidationError

from .blackboard import parse_ref
from .diagnostics import Diagnostic
from .guards import GUARDS
from .loading import MachineNode
from .machine import GuardRef, guard_entries
from .pydantic_errors import diagnostics_from_validation
from .skills import SKILLS, get_skill, skill_names
from .yamlio import SourceMap

__all__ = ["blackboard_keys", "state_outcomes", "validate_guards", "validate_machine"]


def state_outcomes(node: MachineNode, name: str) -> list[str]:
    """Outcomes the state `name` of `node` can end with."""
    st = node.states[name]
    if st.skill is not None:
        out = list(SKILLS[st.skill].outcomes) if st.skill in SKILLS else []
    elif name in node.children:
        out = node.children[name].outcomes()
    else:
        out = []
    if st.timeout is not None and "timeout" not in out:
        out.append("timeout")
    return out


def blackboard_keys(node: MachineNode) -> set[str]:
    """Keys declared anywhere in the tree or written by one of its skills."""
    keys = set(node.blackboard)
    for _, st, _owner in node.walk():
        if st.skill in SKILLS:
            cls = SKILLS[st.skill]
            for fld in cls.writes:
                value = st.with_.get(fld, cls.Params.model_fields[fld].default)
                if isinstance(value, str):
                    keys.add(value)
    for child in node.children.values():
        keys |= blackboard_keys(child)
    return keys


def validate_machine(node: MachineNode, extra_keys: Iterable[str] = ()) -> list[Diagnostic]:
    """Every static problem of `node` and its nested machines."""
    skill_names()  # discover skills
    keys = blackboard_keys(node) | set(extra_keys)
    return _check(node, keys)


def _check(node: MachineNode, keys: set[str]) -> list[Diagnostic]:
    src, at = node.source, node.at
    out: list[Diagnostic] = []
    names = tuple(node.states)
    if node.initial not in node.states:
        out.append(src.diag((*at, "initial"), f"unknown state {node.initial!r}", names))
    if node.on_abort is not None and node.on_abort not in node.states:
        out.append(src.diag((*at, "on_abort"), f"unknown state {node.on_abort!r}", names))
    out += validate_guards(node.guards, src, (*at, "guards"))
    for key, value in node.blackboard.items():
        out += _check_refs(value, keys, src, (*at, "blackboard", key))
    for name, st in node.states.items():
        sat = (*at, "states", name)
        if st.skill is not None:
            if st.skill not in SKILLS:
                out.append(src.diag((*sat, "skill"), f"unknown skill {st.skill!r}", tuple(sorted(SKILLS))))
            else:
                out += _check_params(st.skill, st.with_, keys, src, (*sat, "with"))
        outcomes = state_outcomes(node, name)
        known = st.skill is None or st.skill in SKILLS
        if known and (st.skill is not None or name in node.children):
            for outcome, target in st.transitions.items():
                if outcome not in outcomes:
                    what = f"skill {st.skill!r}" if st.skill else "the nested machine"
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
                out.append(
                    src.diag((*sat, "transitions", outcome), f"unknown state {target!r}", names)
                )
        out += validate_guards(st.guards, src, (*sat, "guards"))
        if name in node.children:
            out += _check(node.children[name], keys)
    out += _check_graph(node)
    return out


def _check_graph(node: MachineNode) -> list[Diagnostic]:
    src, at = node.source, node.at
    states = node.states
    edges = {n: {t for t in st.transitions.values() if t in states} for n, st in states.items()}
    reachable: set[str] = set()
    todo = [s for s in (node.initial, node.on_abort) if s in states]
    while todo:
        s = todo.pop()
        if s not in reachable:
            reachable.add(s)
            todo.extend(edges[s])
    out = []
    for name in states:
        if name not in reachable and node.initial in states:
            out.append(src.diag((*at, "states", name), f"state {name!r} is unreachable from "
                                f"{node.initial!r}: no transition leads to it"))
    finals = {n for n, st in states.items() if st.final is not None}
    can_finish = set(finals)
    changed = True
    while changed:
        changed = False
        for n, targets in edges.items():
            if n not in can_finish and targets & can_finish:
                can_finish.add(n)
                changed = True
    if not finals:
        out.append(src.diag((*at, "states"), "the machine has no final state (add e.g. "
                            "`DONE: {final: succeeded}`)"))
    else:
        for name in states:
            if name in reachable and name not in can_finish:
                out.append(src.diag((*at, "states", name), f"state {name!r} has no path to a final state"))
    return out


def _refs(value: Any, path: tuple) -> Iterable[tuple[tuple, str]]:
    ref = parse_ref(value)
    if ref is not None:
        yield path, ref[0]
    elif isinstance(value, dict):
        for k, v in value.items():
            yield from _refs(v, (*path, k))
    elif isinstance(value, list):
        for i, v in enumerate(value):
            yield from _refs(v, (*path, i))
    elif isinstance(value, str) and value.startswith("$"):
        yield path, value  # malformed reference


def _check_refs(value: Any, keys: set[str], src: SourceMap, path: tuple) -> list[Diagnostic]:
    out = []
    for p, key in _refs(value, path):
        if key.startswith("$"):
            out.append(src.diag(p, f"malformed reference {key!r}: use `$key`, `$key.field` or `$key[0]`"))
        elif key not in keys:
            out.append(src.diag(p, f"`${key}` reads a blackboard key that is never declared or "
                                "written: declare it under `blackboard:`", tuple(sorted(keys))))
    return out


def _check_params(skill: str, params: dict, keys: set[str], src: SourceMap, path: tuple) -> list[Diagnostic]:
    cls = get_skill(skill)
    out = _check_refs(params, keys, src, path)
    concrete = {k: v for k, v in params.items() if not any(True for _ in _refs(v, ()))}
    referenced = set(params) - set(concrete)
    try:
        cls.Params.model_validate(concrete)
    except ValidationError as exc:
        for d in diagnostics_from_validation(exc, cls.Params, src, params, path):
            leaf = d.path.split(".")[-1]
            if "missing required key" in d.message and leaf.strip("'") in referenced:
                continue
            out.append(d)
    return out


def validate_guards(refs: list[GuardRef] | dict, src: SourceMap, path: tuple) -> list[Diagnostic]:
    """Unknown guards and bad guard parameters."""
    out = []
    for pos, name, params in guard_entries(refs):
        gpath = (*path, pos) if isinstance(pos, int) else (*path, pos)
        if name not in GUARDS:
            out.append(src.diag(gpath, f"unknown guard {name!r}", tuple(sorted(GUARDS))))
            continue
        try:
            GUARDS[name].Params.model_validate(params)
        except ValidationError as exc:
            ppath = (*gpath, name) if isinstance(pos, int) else gpath
            out += diagnostics_from_validation(exc, GUARDS[name].Params, src, params, ppath)
    return out
