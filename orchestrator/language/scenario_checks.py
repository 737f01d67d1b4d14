"""Checks of a scenario against its scene: names given to skills, guards and success checks."""

from __future__ import annotations

from typing import Any

import numpy as np

from ..guards import GUARDS
from ..robots import ROBOTS
from ..skills import find_skill
from .diagnostics import Diagnostic
from .faults import HELD
from .goals import goal_keys, item_model  # goal_keys: re-exported
from .loading import MachineNode, initial_values
from .machine import guard_entries
from .param_values import check_values
from .parcels import parcel_name
from .refs import parse_ref
from .scenario import Scenario
from .success import check_success_names
from .validation import written_keys
from .yamlio import SourceMap

__all__ = [
    "goal_keys",
    "check_faults",
    "check_scenario_refs",
    "check_scene_names",
    "scene_bodies",
    "workspace_box",
]


def object_names(scenario: Scenario) -> list[str]:
    """The free objects' names: those of `scene.objects`, then the parcels' (`parcel_00`...;
    drawn per seed, named before)."""
    p = scenario.scene.parcels
    parcels = [parcel_name(i, p.count) for i in range(p.count)] if p is not None else []
    return [o.name for o in scenario.scene.objects] + parcels


def scene_bodies(scenario: Scenario) -> list[str]:
    """Names of the scene's bodies a robot can touch: the world (floor, fixed obstacles), the
    table, the phantom and the free objects."""
    out = ["world", "table"]
    if scenario.scene.phantom is not None:
        out.append(scenario.scene.phantom.name)
    return out + object_names(scenario)


def check_scene_names(
    machine: MachineNode, scenario: Scenario, source: SourceMap
) -> list[Diagnostic]:
    """Skill and guard parameters that name scene objects, markers or zones — given literally
    or through a `$key` whose value is known before the run — must name ones this scenario has.
    """

    objects = object_names(scenario)
    names = {
        "object": ("scene object", objects),
        "gripped_object": ("scene object", [*objects, "*"]),
        "target": ("object or marker", objects + [m.name for m in scenario.scene.markers]),
        "zone": ("no-go zone", [z.name for z in getattr(scenario.scene, "zones", [])]),
        "body": ("scene body", scene_bodies(scenario)),
        "camera": ("camera", [c.name for c in scenario.cameras]),
        "colour_class": ("colour class", list(scenario.perception.classes)),
    }
    values = initial_values(machine, scenario.blackboard)

    def check(src: SourceMap, at: tuple, model, params: dict) -> list[Diagnostic]:
        found = []
        for field, info in model.model_fields.items():
            sub = item_model(info.annotation)
            if sub is not None and isinstance(params.get(field), list):
                for i, item in enumerate(params[field]):  # e.g. `move`'s via points
                    if isinstance(item, dict):
                        found += check(src, (*at, field, i), sub, item)
                continue
            extra = info.json_schema_extra
            kind = extra.get("scene_ref") if isinstance(extra, dict) else None
            key = info.alias or field
            if kind is None or key not in params:
                continue
            value, via = params[key], ""
            ref = parse_ref(value)
            if ref is not None and not ref[1]:
                value, via = values.get(ref[0]), f" (the value of ${ref[0]})"
            what, valid = names[kind]
            for item in value if isinstance(value, list) else [value]:
                if isinstance(item, str) and item not in valid:
                    none = "" if valid else f"; it has no {what}s at all"
                    found.append(
                        src.diag(
                            (*at, key),
                            f"no {what} {item!r} in scenario {scenario.name!r}{via}{none}",
                            tuple(valid),
                        )
                    )
        return found

    robot = ROBOTS.get(scenario.robot.name)

    def guards(src: SourceMap, at: tuple, refs) -> list[Diagnostic]:
        found = []
        for pos, name, params in guard_entries(refs):
            if name in GUARDS and isinstance(params, dict):
                gat = (*at, pos, name) if isinstance(pos, int) else (*at, pos)
                found += check(src, gat, GUARDS[name].Params, params)
                if robot is not None:  # per-joint limits against the robot's datasheet
                    for key, message in GUARDS[name].robot_problems(params, robot):
                        found.append(src.diag((*gat, key), message))
        return found

    out = guards(source, ("guards",), scenario.guards)
    for node in machine.nodes():
        out += guards(node.source, (*node.at, "guards"), node.guards)
        for n, st in node.states.items():
            at = (*node.at, "states", n)
            out += guards(node.source, (*at, "guards"), st.guards)
            cls = find_skill(st.skill or "")
            if cls is not None:
                out += check(node.source, (*at, "with"), cls.Params, st.with_)
                out += _missing_scene(node.source, (*at, "skill"), cls, scenario)
        for s, b, br in node.skill_branches():
            cls = find_skill(br.skill or "")
            if cls is not None:
                at = (*node.at, "states", s, "parallel", b, "with")
                out += check(node.source, at, cls.Params, br.with_)
    # the scenario's values (and `--set`'s) through the parameters that read them
    located = {key: (source, ("blackboard", key)) for key in scenario.blackboard}
    return out + check_values(machine, values, located, written_keys(machine))


def _missing_scene(source: SourceMap, at: tuple, cls: Any, scenario: Scenario) -> list[Diagnostic]:
    """A skill that needs a part of the scene (`needs_scene`) the scenario lacks."""
    return [
        source.diag(
            at,
            f"skill {cls.name!r} needs `scene.{key}`, which scenario {scenario.name!r} has "
            f"not: add one, or use a machine without {cls.name!r}",
        )
        for key in getattr(cls, "needs_scene", ())
        if getattr(scenario.scene, key, None) is None
    ]


def workspace_box(scenario: Scenario) -> tuple[np.ndarray, np.ndarray] | None:
    """The box of the scenario's `workspace` guard, (min, max), world frame [m] (its defaults
    filled in); None without one."""
    for _, name, params in guard_entries(scenario.guards):
        if name == "workspace":
            box = GUARDS[name].Params.model_validate(params)
            return np.asarray(box.min, float), np.asarray(box.max, float)  # type: ignore[attr-defined]
    return None


def check_scenario_refs(
    scenario: Scenario, src: SourceMap, keys: set[str] | None = None
) -> list[Diagnostic]:
    """Success checks name existing objects and markers (or, with `$key`, a blackboard key of
    the machine, `keys`); the robot is a registered one."""
    objects = object_names(scenario)
    markers = [m.name for m in scenario.scene.markers]
    out = check_success_names(scenario.success, src, objects, markers, keys)
    if scenario.robot.name not in ROBOTS:
        out.append(
            src.diag(
                ("robot", "name"), f"unknown robot {scenario.robot.name!r}", tuple(sorted(ROBOTS))
            )
        )
    return out


def check_faults(
    machine: MachineNode, scenario: Scenario, source: SourceMap, n_arm: int
) -> list[Diagnostic]:
    """Faults name states of the machine, objects of the scene and joints of the robot."""
    out = []
    states = {path for path, _, _ in machine.walk()}
    objects = object_names(scenario)
    for i, fault in enumerate(scenario.faults):
        at = ("faults", i)
        if fault.on_enter is not None and fault.on_enter not in states:
            out.append(
                source.diag(
                    (*at, "on_enter"),
                    f"no state {fault.on_enter!r} in machine {machine.name!r}",
                    tuple(sorted(states)),
                )
            )
        obj = getattr(fault, "object", None)
        if obj is not None and obj not in objects and obj != HELD:
            none = "" if objects else "; it has no free objects at all"
            out.append(
                source.diag((*at, "object"), f"no scene object {obj!r}{none}", (*objects, HELD))
            )
        joint = getattr(fault, "joint", None)
        if joint is not None and joint > n_arm:
            out.append(
                source.diag(
                    (*at, "joint"),
                    f"joint {joint} is not an arm joint of robot {scenario.robot.name!r}",
                    tuple(str(j) for j in range(1, n_arm + 1)),
                )
            )
    return out
