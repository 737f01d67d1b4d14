"""Load and statically validate machines and scenarios (with `--set` overrides): the entry
points of the language."""

from __future__ import annotations

import copy
from dataclasses import dataclass
from pathlib import Path

from pydantic import ValidationError

from ..exceptions import ConfigError
from .blackboard_types import check_type
from .bundled import bundled_names, resolve_file
from .diagnostics import Diagnostic
from .events import check_events, parse_event_spec
from .faults import parse_fault_spec
from .loading import MachineNode, load_machine_file
from .overrides import apply_override, parse_override
from .pydantic_errors import diagnostics_from_validation
from .scenario import Scenario
from .scenario_checks import check_faults, check_scenario_refs, check_scene_names
from .validation import blackboard_types, validate_guards, validate_machine
from .yamlio import SourceMap, load_yaml

__all__ = ["LoadedScenario", "load_machine", "load_scenario"]


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


def load_scenario(
    ref: str,
    overrides: list[str] | None = None,
    faults: list[str] | None = None,
    events: list[str] | None = None,
    machine: str | None = None,
) -> LoadedScenario:
    """Load and validate a scenario by path or bundled name.

    Args:
        ref: A scenario file or a bundled name.
        overrides: `--set KEY=VALUE` texts.
        faults: `--fault SPEC` texts, added to the scenario's `faults:`.
        events: `--event T:NAME` texts, added to the scenario's `events:`.
        machine: Run this machine (a path or a bundled name) in the scenario's world instead
            of its own (a live session's task); the scenario's `blackboard:` keeps only the
            keys this machine declares, and its `success:` criteria (written for its own
            machine) are dropped: the machine's outcome judges the task.

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
    node: MachineNode | None = None
    machine_ref = machine if machine is not None else data.get("machine")
    if isinstance(machine_ref, str):
        base = None if machine is not None else path.parent
        mpath = resolve_file(machine_ref, "machines", base)
        if mpath is None:
            problems.append(
                doc.source.diag(
                    ("machine",),
                    f"machine {machine_ref!r} not found (relative to {path.parent}, nor bundled)",
                    tuple(bundled_names("machines")),
                )
            )
        else:
            node, sub = load_machine_file(mpath)
            problems += sub
    types = blackboard_types(node) if node else {}
    keys = set(types)
    if machine is not None and machine != data.get("machine"):
        data["machine"] = machine
        data.pop("success", None)  # the scenario's criteria judge its own machine
        if isinstance(data.get("blackboard"), dict):
            data["blackboard"] = {k: v for k, v in data["blackboard"].items() if k in keys}
    overridden: dict[str, str] = {}
    """Path of a value set on the command line -> the option that set it (`--set k=v`)."""
    for text in faults or []:
        raw = parse_fault_spec(text)
        if isinstance(raw, Diagnostic):
            problems.append(raw)
            continue
        listed = data.setdefault("faults", [])
        if isinstance(listed, list):
            overridden[f"faults[{len(listed)}]"] = f"--fault {text}"
            listed.append(raw)
    for text in events or []:
        raw = parse_event_spec(text)
        if isinstance(raw, Diagnostic):
            problems.append(raw)
            continue
        listed = data.setdefault("events", [])
        if isinstance(listed, list):
            overridden[f"events[{len(listed)}]"] = f"--event {text}"
            listed.append(raw)
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
            ] = f"--set {text}"
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
    if scenario is not None and node is not None and not problems:
        problems += check_scene_names(node, scenario, doc.source)
        problems += check_faults(node, scenario, doc.source, _arm_joints(scenario))
        problems += check_events(node, scenario.events, doc.source)
    if scenario is not None:
        problems += check_scenario_refs(scenario, doc.source)
        if node is not None:
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
    if node is not None:
        problems += validate_machine(node)
    if problems:
        raise ConfigError([_attribute(d, overridden, doc.source.file) for d in problems])
    assert scenario is not None and node is not None
    return LoadedScenario(scenario, node, path, doc.source)


def load_machine(ref: str, base_dir: Path | None = None) -> MachineNode:
    """Load and statically validate a machine by path or bundled name.

    Raises:
        ConfigError: With every problem found, each located in its file.
    """
    path = resolve_file(ref, "machines", base_dir)
    if path is None:
        raise ConfigError(
            [
                Diagnostic(
                    ref,
                    0,
                    0,
                    "<machine>",
                    "no such machine file or bundled machine",
                    tuple(bundled_names("machines")),
                )
            ]
        )
    node, problems = load_machine_file(path)
    if node is not None:
        problems += validate_machine(node)
    if problems:
        raise ConfigError(problems)
    assert node is not None
    return node


def _attribute(diag: Diagnostic, overridden: dict[str, str], file: str) -> Diagnostic:
    """Blame a `--set` or `--fault` option, not the scenario file, for what it set."""
    if diag.file != file:
        return diag
    for path, origin in overridden.items():
        if (
            diag.path == path
            or diag.path.startswith(path + ".")
            or diag.path.startswith(path + "[")
        ):
            option = origin.split(" ", 1)[0]
            return Diagnostic(
                f"<{option}>", 0, 0, diag.path, f"{diag.message} (from {origin})", diag.valid
            )
    return diag


def _arm_joints(scenario: Scenario) -> int:
    from ..robots import ROBOTS

    cls = ROBOTS.get(scenario.robot.name)
    return len(cls.arm_joints) if cls is not None else 64
