"""Load and statically validate machines and scenarios (with `--set` overrides): the entry
points of the language."""

from __future__ import annotations

import copy
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from pydantic import ValidationError

from ..exceptions import ConfigError
from .blackboard_types import all_finite, check_type
from .default_scene import is_machine_data, scenario_for_machine
from .diagnostics import Diagnostic
from .entries import entry_file, unknown_entry
from .events import check_events, parse_event_spec
from .faults import parse_fault_spec
from .includes import resolve_include
from .inputs import check_inputs
from .limits import current_limits
from .loading import MachineNode, load_machine_file
from .machines import load_machine  # re-exported: the entry points live here
from .overrides import Override, apply_override, parcels_alias, parse_override
from .pydantic_errors import diagnostics_from_validation
from .random_goal_checks import check_random_goals
from .robot_gains import check_gains
from .scenario import Scenario
from .scenario_checks import check_faults, check_scenario_refs, check_scene_names, goal_keys
from .scenario_skills import hint_unimported, register_scenario_skills
from .scene_reach import check_scene_reach
from .success import typed_success, validate_success
from .validation import blackboard_types, validate_guards, validate_machine
from .yamlio import SourceMap, load_yaml

if TYPE_CHECKING:
    from ..world.world import World

__all__ = [
    "LoadedScenario",
    "check_blackboard_sets",
    "compile_world",
    "load_machine",
    "load_scenario",
    "load_world",
]


@dataclass
class LoadedScenario:
    """A validated scenario, its machine tree, and where it came from."""

    scenario: Scenario
    machine: MachineNode
    path: Path
    source: SourceMap
    recipe: dict[str, Any] = field(default_factory=dict)
    """The arguments of `load_scenario` that made it, as data (a run snapshot rebuilds the
    run from them: engine/snapshot/run_snapshot.py)."""

    @property
    def name(self) -> str:
        return self.scenario.name


def load_scenario(
    ref: str,
    overrides: Sequence[str | Override | Diagnostic] | None = None,
    faults: list[str] | None = None,
    allow_paths: Sequence[Path | str] = (),
    events: list[str] | None = None,
    machine: str | None = None,
    import_skills: bool = True,
) -> LoadedScenario:
    """Load and validate a scenario by path or bundled name.

    Args:
        ref: A scenario or machine file, or a bundled scenario or machine name (the rule of
            `entries.py`; a machine runs in the default scene).
        overrides: `--set KEY=VALUE` texts, or what `parse_override` made of them.
        faults: `--fault SPEC` texts, added to the scenario's `faults:`.
        allow_paths: Directories outside the scenario's own tree that `machine:` may name
            (`--allow-path`).
        events: `--event T:NAME` texts, added to the scenario's `events:`.
        machine: Run this machine (a path or a bundled name) in the scenario's world instead
            of its own (a live session's task); the scenario's `blackboard:` keeps only the
            keys this machine declares, and its `success:` criteria (written for its own
            machine) are dropped: the machine's outcome judges the task.
        import_skills: Import the scenario's `skills:` folders (commands that run it). False
            for commands that only read it (`validate`, `graph`, `show`): nothing a file names
            is executed, and a skill only those folders define is reported as unknown with
            the fix (`scenario_skills.py`).

    Raises:
        ConfigError: With every problem found in the scenario, its machine and the overrides.
    """
    return _load(ref, overrides, faults, allow_paths, events, machine, import_skills, 0)[0]


def load_world(
    ref: str,
    seed: int,
    overrides: Sequence[str | Override | Diagnostic] | None = None,
    faults: list[str] | None = None,
    allow_paths: Sequence[Path | str] = (),
    events: list[str] | None = None,
) -> tuple[LoadedScenario, World]:
    """`load_scenario`, and the world it compiled to check that MuJoCo builds it: built for
    `seed`, unused, ready to run (engine/prepare.py runs it instead of compiling another).

    Raises:
        ConfigError: As `load_scenario`.
    """
    loaded, world = _load(ref, overrides, faults, allow_paths, events, None, True, seed)
    assert world is not None
    return loaded, world


def compile_world(loaded: LoadedScenario, seed: int) -> World:
    """The world of `loaded` built for `seed` (another seed than the one it was loaded with).

    Raises:
        ConfigError: MuJoCo cannot build the scene drawn for this seed (said as
            `load_scenario` says it).
    """
    world, problems = _compiles(loaded.scenario, loaded.source, seed)
    if problems:
        raise ConfigError(problems)
    assert world is not None
    return world


def _load(
    ref: str,
    overrides: Sequence[str | Override | Diagnostic] | None,
    faults: list[str] | None,
    allow_paths: Sequence[Path | str],
    events: list[str] | None,
    machine: str | None,
    import_skills: bool,
    seed: int,
) -> tuple[LoadedScenario, World | None]:
    path = entry_file(ref)  # a file, else a bundled scenario, else a bundled machine
    if path is None:
        raise ConfigError([unknown_entry(ref)])
    limits = current_limits()
    allow = tuple(Path(a) for a in allow_paths)
    doc = load_yaml(path, limits)
    problems = list(doc.problems)
    data = doc.data
    if is_machine_data(data):
        data = scenario_for_machine(data, path)  # a bare machine: run it in the default scene
    if not isinstance(data, dict):
        problems.append(
            doc.source.diag((), "a scenario file must be a mapping (name, machine, scene, ...)")
        )
        raise ConfigError(problems)
    data = copy.deepcopy(data)
    overridden: dict[str, str] = {}
    """Path of a value set on the command line -> the option that set it (`--set k=v`)."""
    own_machine = data.get("machine")
    parsed = [parse_override(ov) if isinstance(ov, str) else ov for ov in overrides or []]
    for ov in parsed:  # `--set machine=...` chooses the machine: apply it before loading one
        if isinstance(ov, Override) and ov.path == ("machine",):
            if not isinstance(ov.value, str):
                want = f"expected a machine file or bundled name, got {ov.value!r}"
                problems.append(ov.diag(want))
                continue
            data["machine"] = ov.value
            overridden["machine"] = f"--set {ov.text}"
    skill_problems, unimported = register_scenario_skills(
        data.get("skills"), path, allow, doc.source, limits, import_skills
    )
    problems += skill_problems
    node: MachineNode | None = None
    machine_ref = machine if machine is not None else data.get("machine")
    if isinstance(machine_ref, str):
        found = resolve_include(machine_ref, path, allow, limits, what="machine")
        if found.path is None:
            diag = doc.source.diag(("machine",), found.error or "", found.valid)
            problems.append(_attribute(diag, overridden, doc.source.file))
        else:
            node, sub = load_machine_file(found.path, allow, limits)
            problems += sub
    types = blackboard_types(node) if node else {}
    keys = set(types)
    if machine is not None:
        data["machine"] = machine
    if data.get("machine") != own_machine:  # another machine (`machine=` or `--set machine=`)
        data.pop("success", None)  # the scenario's criteria judge its own machine
        if isinstance(data.get("blackboard"), dict):
            data["blackboard"] = {k: v for k, v in data["blackboard"].items() if k in keys}
    problems += _append_options(data, "events", "--event", events, parse_event_spec, overridden)
    problems += _append_options(data, "faults", "--fault", faults, parse_fault_spec, overridden)
    for ov in parsed:
        if isinstance(ov, Diagnostic):
            problems.append(ov)
            continue
        if ov.path == ("machine",):
            continue  # applied above
        alias = parcels_alias(data, ov)  # read before applying: the path it writes
        refused = apply_override(data, ov, keys)
        if refused is not None:
            problems.append(refused)
        else:
            dotted = ".".join(alias or ov.path)
            overridden[
                "blackboard." + dotted if len(ov.path) == 1 and dotted in keys else dotted
            ] = f"--set {ov.text}"
    _fix_randomized(data, overridden)
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
    if "success" in data:  # kinds and their parameters, said with the valid kinds
        problems = [p for p in problems if p.path.split(".")[0] != "success"]
        wrong = validate_success(data["success"], doc.source)
        problems += wrong
        if scenario is not None and not wrong:
            scenario.success = typed_success(scenario.success)  # each as its kind's Params
    if scenario is not None and node is not None:  # before the names it may hold are looked up
        problems += _check_blackboard(scenario, node, types, doc.source)
    if scenario is not None and node is not None and not problems:
        problems += check_scene_names(node, scenario, doc.source)
        problems += check_faults(node, scenario, doc.source, _arm_joints(scenario))
        problems += check_events(node, scenario.events, doc.source)
    if scenario is not None:
        problems += check_scenario_refs(scenario, doc.source, keys if node else None)
        problems += check_gains(scenario.robot.name, scenario.robot.gains, doc.source)
        problems += check_scene_reach(scenario, doc.source)
        if node is not None and not problems:  # the box is checked as goals are
            r = scenario.robot
            problems += check_random_goals(
                scenario.randomize, types, scenario.guards, r.name, r.base_pos, doc.source
            )
    if node is not None:
        problems += validate_machine(node) + check_inputs(node)
    world: World | None = None
    if scenario is not None and not problems:
        world, built = _compiles(scenario, doc.source, seed)
        problems += built
    if problems:
        problems = [hint_unimported(d, unimported) for d in problems]
        raise ConfigError([_attribute(d, overridden, doc.source.file) for d in problems])
    assert scenario is not None and node is not None
    recipe = {
        "ref": str(path.resolve()),
        "overrides": [o if isinstance(o, str) else o.text for o in overrides or []
                      if isinstance(o, str | Override)],
        "faults": list(faults or []),
        "events": list(events or []),
        "allow_paths": [str(Path(a).resolve()) for a in allow],
        "machine": machine,
    }  # fmt: skip
    return LoadedScenario(scenario, node, path, doc.source, recipe), world


def _append_options(
    data: dict,
    key: str,
    option: str,
    texts: list[str] | None,
    parse: Callable[[str], Any],
    overridden: dict[str, str],
) -> list[Diagnostic]:
    """Add command-line `option` texts (`--event`, `--fault`) to the scenario's list `key`,
    remembering which option set each entry (so a problem with it blames the option)."""
    problems = []
    for text in texts or []:
        raw = parse(text)
        if isinstance(raw, Diagnostic):
            problems.append(raw)
            continue
        listed = data.setdefault(key, [])
        if isinstance(listed, list):
            overridden[f"{key}[{len(listed)}]"] = f"{option} {text}"
            listed.append(raw)
    return problems


def _check_blackboard(
    scenario: Scenario, node: MachineNode, types: dict[str, str], source: SourceMap
) -> list[Diagnostic]:
    """The scenario's `blackboard:` values (with `--set` ones): keys the machine declares,
    finite numbers, goals that are numbers and not text, values of the declared type."""
    goals = goal_keys(node)
    problems = []
    for key, value in scenario.blackboard.items():
        at = ("blackboard", key)
        if key not in types:
            want = f"the machine has no blackboard key {key!r}"
            problems.append(source.diag(at, want, tuple(sorted(types))))
        elif not all_finite(value):
            problems.append(source.diag(at, f"{value!r} is not finite: give finite numbers"))
        elif key in goals and (why := _number_as_text(value)) is not None:
            problems.append(source.diag(at, why))
        elif not check_type(value, types[key]):
            problems.append(
                source.diag(
                    at,
                    f"{value!r} is not a {types[key]}, the type the machine declares for this key",
                )
            )
    return problems


def check_blackboard_sets(loaded: LoadedScenario, texts: Sequence[str]) -> dict[str, Any]:
    """`--set KEY=VALUE` for a machine already running (`run --from SNAPSHOT`): blackboard
    keys the machine declares, checked as a scenario's `blackboard:` values are (the type the
    machine declares, finite numbers, goals as numbers). Scenario values are refused: they
    were built into the world when the run started.

    Returns:
        Key -> value.

    Raises:
        ConfigError: Every problem, each located at `<--set>` with the valid keys.
    """
    types = blackboard_types(loaded.machine)
    values: dict[str, Any] = {}
    problems: list[Diagnostic] = []
    origin: dict[str, str] = {}
    for text in texts:
        ov = parse_override(text)
        if isinstance(ov, Diagnostic):
            problems.append(ov)
            continue
        if len(ov.path) != 1 or ov.path[0] not in types:
            why = (
                "not a blackboard key of this machine"
                if len(ov.path) == 1
                else "a resumed run changes blackboard keys only: scenario values were built "
                "into its world when it started"
            )
            problems.append(ov.diag(why, tuple(sorted(types))))
            continue
        values[ov.path[0]] = ov.value
        origin[ov.path[0]] = ov.text
    stand_in = Scenario.model_construct(blackboard=values)
    for diag in _check_blackboard(stand_in, loaded.machine, types, loaded.source):
        key = diag.path.removeprefix("blackboard.")
        message = f"{diag.message} (from --set {origin.get(key, key)})"
        problems.append(Diagnostic("<--set>", 0, 0, key, message, diag.valid))
    if problems:
        raise ConfigError(problems)
    return values


def _number_as_text(value: object) -> str | None:
    """Why a goal (a target the arm moves to) holding a number spelled as text is refused:
    `NaN` and `inf` are text in YAML, and so is `1e308` (YAML wants `1.0e+308`); as text they
    would be looked up as object or marker names."""
    for item in value if isinstance(value, list) else [value]:
        if not isinstance(item, str):
            continue
        try:
            number = float(item)
        except ValueError:
            continue
        if not math.isfinite(number):
            return f"{item!r} is not finite: give finite numbers [m]"
        return (
            f"{item!r} is text, not a number: YAML reads an exponent only with a decimal point "
            f"and a sign (write {number:.1e}), or give a name of an object or marker"
        )
    return None


def _fix_randomized(data: dict, overridden: dict[str, str]) -> None:
    """A blackboard key set with `--set` is that value in every seed: not drawn any more."""
    randomize = data.get("randomize")
    drawn = randomize.get("blackboard") if isinstance(randomize, dict) else None
    if not isinstance(drawn, dict):
        return
    for path in overridden:
        key = path.removeprefix("blackboard.")
        if path.startswith("blackboard.") and key in drawn:
            del drawn[key]


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


def _compiles(
    scenario: Scenario, source: SourceMap, seed: int
) -> tuple[World | None, list[Diagnostic]]:
    """Build the scenario's world once, for `seed` (about 10 ms): what MuJoCo refuses to
    compile is reported by `validate` too, not only by `run` after the user waited for it."""
    from ..world.world import World

    try:
        world = World.build(scenario, seed)
    except Exception as exc:  # MjSpec reports bad geometry as ValueError or its own errors
        text = " ".join(str(exc).split()) or type(exc).__name__
        return None, [source.diag(("scene",), f"MuJoCo cannot build this scene: {text}")]
    inside = _start_contacts(world)
    if inside:
        # found by `orchestrator explore`: a table raised into the arm's home pose was
        # accepted, and the first physics step threw the arm out at 24 rad/s
        name, depth = max(inside.items(), key=lambda kv: kv[1])
        return None, [source.diag(("scene",), (
            f"the robot at its start pose is inside {name} ({depth * 1000:.1f} mm deep"
            f"{' at seed ' + str(seed) if seed else ''}): the scene must leave the arm's start "
            "pose clear (lower `scene.table.height`, or move what it touches)"))]  # fmt: skip
    overlaps = _object_overlaps(world)
    if overlaps:
        # found by `orchestrator explore` on stack: a box drawn 0.67 m long lay on the other
        # cube, and the hand struck it at 66 N, two joints past their datasheet acceleration
        (a, b), depth = max(overlaps.items(), key=lambda kv: kv[1])
        return None, [source.diag(("scene", "objects"), (
            f"{a} starts inside {b} ({depth * 1000:.1f} mm deep"
            f"{' at seed ' + str(seed) if seed else ''}): objects drawn into one another "
            "would be thrown apart by the first physics step or rest on each other; move them "
            "apart or narrow their `randomize` ranges"))]  # fmt: skip
    return world, []


def _start_contacts(world: World) -> dict[str, float]:
    """What the robot penetrates at its start pose: geom name -> depth [m] (a copy of the
    state is forwarded: the run's own `MjData` is not touched)."""
    import mujoco

    model = world.model
    data = mujoco.MjData(model)
    data.qpos[:] = world.data.qpos
    mujoco.mj_forward(model, data)
    robot = world.robot_geoms
    out: dict[str, float] = {}
    for i in range(data.ncon):
        c = data.contact[i]
        g1, g2 = int(c.geom1), int(c.geom2)
        if (g1 in robot) == (g2 in robot) or c.dist >= 0.0:
            continue
        other = g2 if g1 in robot else g1
        name = model.geom(other).name or f"geom {other}"
        out[name] = max(out.get(name, 0.0), -float(c.dist))
    return out


_OVERLAP_M = 0.001
"""Penetration of a free object into another body at the start that is an overlap (objects
laid out touching, or standing on a surface, are at 0)."""


def _object_overlaps(world: World) -> dict[tuple[str, str], float]:
    """Free objects that start inside another object or a fixed body (not the robot: see
    `_start_contacts`): (object, other) -> depth [m] beyond `_OVERLAP_M`."""
    import mujoco

    model = world.model
    data = mujoco.MjData(model)
    data.qpos[:] = world.data.qpos
    mujoco.mj_forward(model, data)
    objects = {h.geom_id: name for name, h in world.objects.items()}
    robot = world.robot_geoms
    out: dict[tuple[str, str], float] = {}
    for i in range(data.ncon):
        c = data.contact[i]
        g1, g2 = int(c.geom1), int(c.geom2)
        if g1 in robot or g2 in robot or -float(c.dist) <= _OVERLAP_M:
            continue
        if g1 not in objects and g2 not in objects:
            continue
        obj, other = (g1, g2) if g1 in objects else (g2, g1)
        pair = (objects[obj], objects.get(other) or model.geom(other).name or f"geom {other}")
        out[pair] = max(out.get(pair, 0.0), -float(c.dist))
    return out


def _arm_joints(scenario: Scenario) -> int:
    from ..robots import ROBOTS

    cls = ROBOTS.get(scenario.robot.name)
    return len(cls.arm_joints) if cls is not None else 64
