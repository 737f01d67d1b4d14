"""Load a scenario, apply `--set` overrides, load and validate its machine."""

from __future__ import annotations

import copy
from dataclasses import dataclass
from pathlib import Path

from pydantic import ValidationError

from .blackboard_types import check_type
from .bundled import bundled_names, resolve_file
from .diagnostics import Diagnostic
from .exceptions import ConfigError
from .loading import MachineNode, load_machine_file
from .overrides import apply_override, parse_override
from .pydantic_errors import diagnostics_from_validation
from .scenario import Scenario
from .validation import blackboard_types, validate_guards, validate_machine
from .yamlio import SourceMap, load_yaml

__all__ = ["LoadedScenario", "load_scenario"]


@dataclass
class LoadedScenario:
    """A validated scenario, its machine tree, and where it came from."""

    scenario: Scenario
    machine: MachineNode
    path: Path
    source: SourceMap

    @property
    def name(self) -> str:
        return self.scenario.name


def load_scenario(ref: str, overrides: list[str] | None = None) -> LoadedScenario:
    """Load and validate a scenario by path or bundled name.

    Raises:
        ConfigError: With every problem found in the scenario, its machine and the overrides.
    """
    path = resolve_file(ref, "scenarios")
    if path is None:
        raise ConfigError(
            [
                Diagnostic(
                    ref,
                    0,
                    0,
                    "<scenario>",
                    "no such scenario file or bundled scenario",
                    tuple(bundled_names("scenarios")),
                )
            ]
        )
    doc = load_yaml(path)
    problems = list(doc.problems)
    data = doc.data
    if not isinstance(data, dict):
        problems.append(
            doc.source.diag((), "a scenario file must be a mapping (name, machine, scene, ...)")
        )
        raise ConfigError(problems)
    data = copy.deepcopy(data)
    machine: MachineNode | None = None
    machine_ref = data.get("machine")
    if isinstance(machine_ref, str):
        mpath = resolve_file(machine_ref, "machines", path.parent)
        if mpath is None:
            problems.append(
                doc.source.diag(
                    ("machine",),
                    f"machine {machine_ref!r} not found (relative to {path.parent}, nor bundled)",
                    tuple(bundled_names("machines")),
                )
            )
        else:
            machine, sub = load_machine_file(mpath)
            problems += sub
    types = blackboard_types(machine) if machine else {}
    keys = set(types)
    overridden: dict[str, str] = {}
    for text in overrides or []:
        ov = parse_override(text)
        if isinstance(ov, Diagnostic):
            problems.append(ov)
            continue
        diag = apply_override(data, ov, keys)
        if diag is not None:
            problems.append(diag)
        else:
            dotted = ".".join(ov.path)
            overridden[
                "blackboard." + dotted if len(ov.path) == 1 and dotted in keys else dotted
            ] = text
    scenario: Scenario | None = None
    try:
        scenario = Scenario.model_validate(data)
    except ValidationError as exc:
        problems += diagnostics_from_validation(exc, Scenario, doc.source, data)
    raw_guards = data.get("guards")
    if isinstance(raw_guards, (list, dict)):
        # guard names and parameters are checked here, with better messages than the model's
        problems = [
            p
            for p in problems
            if not p.path.startswith("guards.") and not p.path.startswith("guards[")
        ]
        problems += validate_guards(raw_guards, doc.source, ("guards",))
    if scenario is not None and machine is not None and not problems:
        problems += _check_scene_names(machine, scenario, doc.source)
    if scenario is not None:
        problems += _check_scenario_refs(scenario, doc.source)
        if machine is not None:
            for key, value in scenario.blackboard.items():
                if key not in keys:
                    problems.append(
                        doc.source.diag(
                            ("blackboard", key),
                            f"the machine has no blackboard key {key!r}",
                            tuple(sorted(keys)),
                        )
                    )
                elif not check_type(value, types[key]):
                    problems.append(
                        doc.source.diag(
                            ("blackboard", key),
                            f"{value!r} is not a {types[key]}, the type the "
                            "machine declares for this key",
                        )
                    )
    if machine is not None:
        problems += validate_machine(machine)
    if problems:
        raise ConfigError([_attribute(d, overridden, doc.source.file) for d in problems])
    assert scenario is not None and machine is not None
    return LoadedScenario(scenario, machine, path, doc.source)


def _attribute(diag: Diagnostic, overridden: dict[str, str], file: str) -> Diagnostic:
    """Blame a `--set` override, not the scenario file, for problems in what it set."""
    if diag.file != file:
        return diag
    for path, text in overridden.items():
        if (
            diag.path == path
            or diag.path.startswith(path + ".")
            or diag.path.startswith(path + "[")
        ):
            return Diagnostic(
                "<--set>", 0, 0, diag.path, f"{diag.message} (from --set {text})", diag.valid
            )
    return diag


def _check_scene_names(
    machine: MachineNode, scenario: Scenario, source: SourceMap
) -> list[Diagnostic]:
    """Skill and guard parameters that name scene objects, markers or zones — given literally
    or through a `$key` whose value is known before the run — must name ones this scenario has.
    """
    from .blackboard import parse_ref
    from .guards import GUARDS
    from .machine import guard_entries
    from .runner import initial_blackboard
    from .skills import SKILLS, skill_names

    skill_names()  # discover the skills
    objects = [o.name for o in scenario.scene.objects]
    names = {
        "object": ("scene object", objects),
        "target": ("object or marker", objects + [m.name for m in scenario.scene.markers]),
        "zone": ("no-go zone", [z.name for z in getattr(scenario.scene, "zones", [])]),
    }
    values = initial_blackboard(machine, scenario.blackboard).as_dict()

    def check(src: SourceMap, at: tuple, model, params: dict) -> list[Diagnostic]:
        found = []
        for field, info in model.model_fields.items():
            extra = info.json_schema_extra
            kind = extra.get("scene_ref") if isinstance(extra, dict) else None
            if kind is None or field not in params:
                continue
            value, via = params[field], ""
            ref = parse_ref(value)
            if ref is not None and not ref[1]:
                value, via = values.get(ref[0]), f" (the value of ${ref[0]})"
            what, valid = names[kind]
            for item in value if isinstance(value, list) else [value]:
                if isinstance(item, str) and item not in valid:
                    none = "" if valid else f"; it has no {what}s at all"
                    found.append(
                        src.diag(
                            (*at, field),
                            f"no {what} {item!r} in scenario {scenario.name!r}{via}{none}",
                            tuple(valid),
                        )
                    )
        return found

    def guards(src: SourceMap, at: tuple, refs) -> list[Diagnostic]:
        found = []
        for pos, name, params in guard_entries(refs):
            if name in GUARDS and isinstance(params, dict):
                gat = (*at, pos, name) if isinstance(pos, int) else (*at, pos)
                found += check(src, gat, GUARDS[name].Params, params)
        return found

    out = guards(source, ("guards",), scenario.guards)
    for node in machine.nodes():
        out += guards(node.source, (*node.at, "guards"), node.guards)
        for n, st in node.states.items():
            at = (*node.at, "states", n)
            out += guards(node.source, (*at, "guards"), st.guards)
            cls = SKILLS.get(st.skill or "")
            if cls is not None:
                out += check(node.source, (*at, "with"), cls.Params, st.with_)
        for s, b, br in node.skill_branches():
            cls = SKILLS.get(br.skill or "")
            if cls is not None:
                at = (*node.at, "states", s, "parallel", b, "with")
                out += check(node.source, at, cls.Params, br.with_)
    return out


def _check_scenario_refs(scenario: Scenario, src: SourceMap) -> list[Diagnostic]:
    out = []
    objects = [o.name for o in scenario.scene.objects]
    markers = [m.name for m in scenario.scene.markers]
    for name, check in scenario.success.items():
        if check.object not in objects:
            out.append(
                src.diag(
                    ("success", name, "object"), f"no scene object {check.object!r}", tuple(objects)
                )
            )
        if check.target is not None and check.target not in markers:
            out.append(
                src.diag(("success", name, "target"), f"no marker {check.target!r}", tuple(markers))
            )
    from .robots import ROBOTS

    if scenario.robot.name not in ROBOTS:
        out.append(
            src.diag(
                ("robot", "name"), f"unknown robot {scenario.robot.name!r}", tuple(sorted(ROBOTS))
            )
        )
    return out
