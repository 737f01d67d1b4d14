"""Static checks of a loaded machine tree: everything that can be known before simulating."""

from __future__ import annotations

import re
from collections.abc import Iterable
from typing import Any

from pydantic import ValidationError

from ..guards import GUARDS
from ..skills import SKILLS, get_skill, skill_names
from .blackboard_types import all_finite, check_type, sample_value
from ..world.pose import Pose
from .diagnostics import Diagnostic, did_you_mean, format_path
from .loading import MachineNode, initial_values
from .machine import (
    BLACKBOARD_TYPES,
    BUILTIN_EVENTS,
    BranchSpec,
    GuardRef,
    StateSpec,
    guard_entries,
)
from .pydantic_errors import diagnostics_from_validation
from .refs import parse_ref
from .yamlio import SourceMap

__all__ = [
    "RUN_OUTCOMES",
    "blackboard_keys",
    "blackboard_types",
    "branch_outcomes",
    "check_values",
    "pose_problem",
    "ref_type",
    "skill_writes",
    "state_outcomes",
    "validate_guards",
    "validate_machine",
]

POSE_FIELDS = ("pos", "quat")
_EVENT_NAME = re.compile(r"[a-z][a-z0-9_]*")


def skill_writes(skill: str, params: dict) -> dict[str, str]:
    """Blackboard key -> type that a skill state writes (from its `writes` declaration)."""
    cls = SKILLS.get(skill)
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
    out = list(SKILLS[branch.skill].outcomes) if branch.skill in SKILLS else []
    if branch.timeout is not None and "timeout" not in out:
        out.append("timeout")
    return out


def state_outcomes(node: MachineNode, name: str) -> list[str]:
    """Outcomes the state `name` of `node` can end with; the first one is its success."""
    st = node.states[name]
    if st.skill is not None:
        out = list(SKILLS[st.skill].outcomes) if st.skill in SKILLS else []
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
    skill_names()
    return set(blackboard_types(node))


def validate_machine(node: MachineNode, extra_keys: Iterable[str] = ()) -> list[Diagnostic]:
    """Every static problem of `node` and its nested machines."""
    skill_names()  # discover skills
    types = blackboard_types(node)
    for key in extra_keys:
        types.setdefault(key, "any")
    out = _check(node, types, set())
    if not out:  # the defaults, through the parameters that read them
        out += check_values(node, initial_values(node, {}), _declared_at(node))
    return out


def _declared_at(node: MachineNode) -> dict[str, tuple[SourceMap, tuple]]:
    """Where each blackboard key's default is declared (the outermost declaration wins, as
    in `initial_values`)."""
    where: dict[str, tuple[SourceMap, tuple]] = {}
    for sub in reversed(list(node.nodes())):
        for key in sub.blackboard:
            where[key] = (sub.source, (*sub.at, "blackboard", key))
    where.update({k: (node.source, (*node.at, "blackboard", k)) for k in node.blackboard})
    return where


def check_values(
    node: MachineNode, values: dict[str, Any], located: dict[str, tuple[SourceMap, tuple]]
) -> list[Diagnostic]:
    """Values known before the run, through the skill parameters that read them.

    A key no skill writes holds its initial value all run long, so a parameter that reads it
    (`target: $place_at`) can be checked with that value now rather than when its state
    starts, after the arm has moved: `--set place_at=[0.4, 0.25]` is refused before anything
    moves. Each problem is said where the value is set (`located`: key -> source and path,
    e.g. the scenario's `blackboard.place_at`, which `--set` writes) and names the state and
    parameter that cannot take it.

    Args:
        node: The machine tree.
        values: Initial blackboard values.
        located: The keys to check, with where each one's value is written.
    """
    written = {k for sub in node.nodes() for k in skill_writes_of(sub)}
    readers: dict[tuple[str, str, str], list[str]] = {}
    """(key, its value, the problem) -> the parameters that cannot take the key's value."""
    for sub in node.nodes():
        for at, skill, params in _skill_params(sub):
            cls = SKILLS.get(skill)
            if cls is None:
                continue
            known = {}
            for name, raw in params.items():
                ref = parse_ref(raw)
                if ref is None or ref[0] in written or ref[0] not in located:
                    continue
                try:
                    known[name] = _read(values.get(ref[0]), ref[1])
                except (KeyError, IndexError, TypeError, AttributeError):
                    continue  # the reference check reports a path that cannot be read
            for name, problem in _field_problems(cls.Params, params, known).items():
                ref = parse_ref(params[name])
                assert ref is not None
                line, _ = sub.source.locate((*at, "with", name))
                state = format_path(at[at.index("states") + 1 :] if "states" in at else at)
                reader = f"`{params[name]}` in {state}.with.{name} ({sub.source.file}:{line})"
                readers.setdefault((ref[0], repr(known[name]), problem), []).append(reader)
    out = []
    for (key, value, problem), where in readers.items():
        src, path = located[key]
        out.append(src.diag(path, f"{value} cannot be read by {', '.join(where)}: {problem}"))
    return out


def _skill_params(node: MachineNode) -> Iterable[tuple[tuple, str, dict]]:
    """(path of the state or branch, skill, `with:`) of every skill this level runs."""
    for name, st in node.states.items():
        if st.skill is not None:
            yield (*node.at, "states", name), st.skill, st.with_
    for name, bname, branch in node.skill_branches():
        yield (*node.at, "states", name, "parallel", bname), branch.skill or "", branch.with_


def _read(value: Any, rest: list[str | int]) -> Any:
    for part in rest:
        value = value[part] if isinstance(part, int) or isinstance(value, dict) else None
        if value is None:
            raise KeyError(part)
    if value is None:
        raise KeyError("no value yet")
    return value


def _field_problems(model: type, params: dict, known: dict[str, Any]) -> dict[str, str]:
    """Why each of the `known` values cannot be the parameter it is given to."""
    if not known:
        return {}
    out: dict[str, str] = {}
    concrete = {k: v for k, v in params.items() if not _has_ref(v)}
    try:
        model.model_validate({**concrete, **known})  # type: ignore[attr-defined]
    except ValidationError as exc:
        for err in exc.errors(include_url=False):
            name = err["loc"][0] if err["loc"] else None
            if name in known and name not in out:
                where = ".".join(str(p) for p in err["loc"][1:])
                out[name] = (f"{where}: " if where else "") + str(err["msg"])
    fields = model.model_fields  # type: ignore[attr-defined]
    for name, value in known.items():
        extra = fields[name].json_schema_extra if name in fields else None
        is_target = isinstance(extra, dict) and extra.get("scene_ref") == "target"
        if name not in out and is_target and not isinstance(value, str):
            problem = pose_problem(value)
            if problem is not None:
                out[name] = problem
    return out


def pose_problem(value: Any) -> str | None:
    """Why `value` is not a pose a motion can go to (`[x, y, z]` [m] or `{pos, quat}`), or None."""
    try:
        Pose.coerce(value)
    except ValidationError as exc:
        err = exc.errors(include_url=False)[0]
        where = ".".join(str(p) for p in err["loc"])
        return f"not a pose: {where}: {err['msg']} (give [x, y, z] in metres or {{pos, quat}})"
    except (TypeError, ValueError):
        return "not a pose: give [x, y, z] in metres, {pos, quat}, or an object or marker name"
    return None


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
        if st.skill not in SKILLS:
            known = False
            out.append(_unknown_skill(src, (*sat, "skill"), st.skill))
        else:
            out += _check_params(st.skill, st.with_, types, src, (*sat, "with"))
    if st.parallel is not None:
        for bname, branch in node.branches.get(name, {}).items():
            if isinstance(branch, BranchSpec) and branch.skill is not None:
                bat = (*sat, "parallel", bname)
                if branch.skill not in SKILLS:
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
            out.append(_unknown_state(src, (*sat, "transitions", outcome), target, names))
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


def _unknown_state(src: SourceMap, at: tuple, name: str, names: tuple[str, ...]) -> Diagnostic:
    return src.diag(at, f"unknown state {name!r}{did_you_mean(name, names)}", names)


def _unknown_skill(src: SourceMap, at: tuple, name: str) -> Diagnostic:
    names = tuple(sorted(SKILLS))
    return src.diag(at, f"unknown skill {name!r}{did_you_mean(name, names)}", names)


def _refs(value: Any, path: tuple) -> Iterable[tuple[tuple, str, list]]:
    ref = parse_ref(value)
    if ref is not None:
        yield path, ref[0], ref[1]
    elif isinstance(value, dict):
        for k, v in value.items():
            yield from _refs(v, (*path, k))
    elif isinstance(value, list):
        for i, v in enumerate(value):
            yield from _refs(v, (*path, i))
    elif isinstance(value, str) and value.startswith("$"):
        yield path, value, []  # malformed reference


_STEPS: dict[str, dict[str | int, str]] = {
    "pose": {"pos": "vec3", "quat": "quat"},
    "vec3": {0: "float", 1: "float", 2: "float"},
    "quat": {0: "float", 1: "float", 2: "float", 3: "float"},
}
"""What a `.field` or `[i]` read of a value of each structured type gives."""
_QUAT_SAMPLE = [1.0, 0.0, 0.0, 0.0]


def ref_type(type_: str, rest: list[str | int], ref: str) -> tuple[str | None, str | None]:
    """The type a `$key.field[i]` read gives, from the key's `type_` and the parts after it.

    Returns:
        (type, problem): the type read (None when it cannot be known: `any`, `list`, `dict`),
        or a problem naming the first part that cannot be read, with the ones that can.
    """
    shown = ref.split(".")[0].split("[")[0]  # `$key`, then each part as it is read
    for part in rest:
        steps = _STEPS.get(type_)
        if type_ in ("any", "list", "dict"):
            return None, None
        step = f".{part}" if isinstance(part, str) else f"[{part}]"
        if steps is None:
            return None, f"`{shown}` is a {type_}: it has no fields or items (not {step})"
        if part not in steps:
            if type_ == "pose":
                return None, f"`{shown}` is a pose: read `.pos` or `.quat`, not {part!r}"
            items = ", ".join(f"[{i}]" for i in steps)
            return None, f"`{shown}` is a {type_}: index it with {items}, not {step}"
        type_ = steps[part]
        shown += step
    return (None if type_ == "any" else type_), None


def _sample(type_: str | None) -> Any:
    return _QUAT_SAMPLE if type_ == "quat" else sample_value(type_ or "any")


def _check_refs(value: Any, types: dict[str, str], src: SourceMap, path: tuple) -> list[Diagnostic]:
    out = []
    for p, key, rest in _refs(value, path):
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
            _, problem = ref_type(types[key], rest, _ref_text(key, rest))
            if problem is not None:
                valid = POSE_FIELDS if "is a pose: read" in problem else ()
                out.append(src.diag(p, problem, valid))
    return out


def _ref_text(key: str, rest: list[str | int]) -> str:
    return "$" + key + "".join(f".{r}" if isinstance(r, str) else f"[{r}]" for r in rest)


def _substitute(value: Any, types: dict[str, str]) -> Any:
    """Replace whole-value `$key` references by a sample of the type they read (None if it
    cannot be known)."""
    ref = parse_ref(value)
    if ref is not None:
        key, rest = ref
        type_, problem = ref_type(types.get(key, "any"), rest, value)
        return None if problem is not None else _sample(type_)
    if isinstance(value, dict):
        return {k: _substitute(v, types) for k, v in value.items()}
    if isinstance(value, list):
        return [_substitute(v, types) for v in value]
    return value


def _has_ref(value: Any) -> bool:
    return any(True for _ in _refs(value, ()))


def _check_params(
    skill: str, params: dict, types: dict[str, str], src: SourceMap, path: tuple
) -> list[Diagnostic]:
    cls = get_skill(skill)
    out = _check_refs(params, types, src, path)
    concrete = {}
    unknown_refs = set()
    for k, v in params.items():
        if not _has_ref(v):
            concrete[k] = v
            continue
        sub = _substitute(v, types)
        if sub is None or (isinstance(sub, (list, dict)) and _contains_none(sub)):
            unknown_refs.add(k)  # untyped reference: checked when the state starts
        else:
            concrete[k] = sub
    for name, info in cls.Params.model_fields.items():
        extra = info.json_schema_extra
        value = params.get(info.alias or name)
        if isinstance(extra, dict) and extra.get("scene_ref") == "target":
            if isinstance(value, (list, dict)) and not _has_ref(value):
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
            ref = parse_ref(params.get(leaf))
            if ref is not None and any(m in d.message for m in _RANGE_MESSAGES):
                continue  # the sample of the key's type is out of range, not the key's value
            if ref is not None:  # a typed `$key` whose type does not fit the parameter
                declared, _ = ref_type(types.get(ref[0], "any"), ref[1], params[leaf])
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
