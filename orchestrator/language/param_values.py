"""Values known before the run, checked through the skill parameters that read them.

A blackboard key no skill writes holds its initial value all run long (a machine's default,
the scenario's value, `--set`), so a parameter that reads it (`target: $place_at`) can be
checked with that value before anything moves, not when its state starts.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

from pydantic import ValidationError

from ..skills import find_skill
from ..world.pose import Pose
from .diagnostics import Diagnostic, format_path
from .loading import MachineNode
from .refs import has_ref, parse_ref
from .yamlio import SourceMap

__all__ = ["check_values", "declared_at", "pose_problem"]


def declared_at(node: MachineNode) -> dict[str, tuple[SourceMap, tuple]]:
    """Where each blackboard key's default is declared (the outermost declaration wins, as
    in `initial_values`)."""
    where: dict[str, tuple[SourceMap, tuple]] = {}
    for sub in reversed(list(node.nodes())):
        for key in sub.blackboard:
            where[key] = (sub.source, (*sub.at, "blackboard", key))
    where.update({k: (node.source, (*node.at, "blackboard", k)) for k in node.blackboard})
    return where


def check_values(
    node: MachineNode,
    values: dict[str, Any],
    located: dict[str, tuple[SourceMap, tuple]],
    written: set[str],
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
        written: The keys some skill writes (their values change while running).
    """
    readers: dict[tuple[str, str, str], list[str]] = {}
    """(key, its value, the problem) -> the parameters that cannot take the key's value."""
    for sub in node.nodes():
        for at, skill, params in _skill_params(sub):
            cls = find_skill(skill)
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
    concrete = {k: v for k, v in params.items() if not has_ref(v)}
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
