"""Reference pages generated from the code: every skill, guard and scenario key with its type,
unit, default and range (`orchestrator show`, docs/skills.md, docs/scenario-reference.md).

The text comes from the pydantic models and the classes' docstrings, so the docs cannot drift
from the code: tests/test_reference.py regenerates the pages and compares.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from pydantic import BaseModel
from pydantic_core import PydanticUndefined

from ..guards import bundled_guards
from ..guards.base import Guard
from ..skills import Skill, bundled_skill_names, get_skill
from ..success import CHECKS, SuccessCheck, bundled_check_kinds
from ..success.params import CheckParams
from .scenario import Scenario

__all__ = [
    "DOCS_DIR",
    "ParamRow",
    "check_markdown",
    "guard_markdown",
    "param_rows",
    "scenario_reference",
    "skill_markdown",
    "skills_reference",
    "write_reference_docs",
]

DOCS_DIR = Path(__file__).resolve().parent.parent.parent / "docs"
"""Where the generated pages live in a clone."""
_UNIT = re.compile(r"\s*\[([^\]]+)\]\.?$")
"""A unit at the end of a description: `Position tolerance [m].`"""
_INNER_UNIT = re.compile(
    r"(?<![`\w])\[((?:1/)?[A-Za-z%]+(?:[/*^·][A-Za-z0-9%]+)*(?:\^[0-9])?)\](?!`)"
)
"""A unit inside a description (`Speed limit [m/s] (capped by the base's).`): a bracketed
word like `m`, `m/s`, `rad/s^2`, `N/m`, `1/rad` — not a list (`[x, y, z]`) or code."""


_SUFFIX_UNITS = (
    ("_deg", "deg"),
    ("_mm", "mm"),
    ("_rad", "rad"),
    ("_m", "m"),
    ("_s", "s"),
    ("_n", "N"),
    ("_hz", "Hz"),
    ("_kg", "kg"),
)
"""The unit a parameter's name ends in, when its description does not say one."""


@dataclass(frozen=True)
class ParamRow:
    """One parameter of a model, as the reference shows it."""

    name: str
    kind: str
    unit: str
    default: str
    range: str
    description: str
    model: type[BaseModel] | None = None
    """The nested model of this key, when it is one (a section of its own)."""


def param_rows(model: type[BaseModel]) -> list[ParamRow]:
    """The model's fields in declaration order, with their type, unit, default and range."""
    schema = model.model_json_schema()
    props = schema.get("properties", {})
    rows = []
    for name, field in model.model_fields.items():
        prop = props.get(name, {})
        text = (field.description or "").strip()
        unit = ""
        match = _UNIT.search(text)
        inner = [m.group(1) for m in _INNER_UNIT.finditer(text)]
        kind = _type_text(prop, schema.get("$defs", {}))
        if match is not None and "," not in match.group(1):  # not a list: `[0, 0, -1]`
            unit, text = match.group(1), text[: match.start()].strip()
        elif inner and kind != "any":  # the unit stated mid-sentence (each, if mixed)
            unit = inner[0] if len(set(inner)) == 1 else ", ".join(inner)
        else:
            unit = next((u for suffix, u in _SUFFIX_UNITS if name.endswith(suffix)), "")
        if kind == "str":
            unit = ""  # a name (a blackboard key, a marker), whatever its value measures
        if field.is_required():
            default = "required"
        elif field.default_factory is not None:
            default = _value(field.default_factory())  # type: ignore[call-arg]
        else:
            default = _value(field.default) if field.default is not PydanticUndefined else ""
        rows.append(
            ParamRow(
                name,
                kind,
                unit,
                default,
                _range_text(prop),
                text,
                _nested_model(field.annotation),
            )
        )
    return rows


def _value(value: Any) -> str:
    if isinstance(value, BaseModel):
        return "see below"
    return json.dumps(value) if value is not None else "null"


def _nested_model(annotation: Any) -> type[BaseModel] | None:
    candidates = [annotation, *getattr(annotation, "__args__", ())]
    for cand in candidates:
        for inner in (cand, *getattr(cand, "__args__", ())):
            if isinstance(inner, type) and issubclass(inner, BaseModel):
                return inner
    return None


def _type_text(prop: dict, defs: dict) -> str:
    if "$ref" in prop:
        return prop["$ref"].rsplit("/", 1)[-1]
    if "enum" in prop:
        return " \\| ".join(f"`{v}`" for v in prop["enum"])
    if "anyOf" in prop:
        parts = [_type_text(p, defs) for p in prop["anyOf"]]
        return " \\| ".join(p for p in parts if p)
    kind = prop.get("type")
    if kind == "array":
        item = _type_text(prop.get("items", {}), defs) or "any"
        n_min, n_max = prop.get("minItems"), prop.get("maxItems")
        size = f"[{n_min}]" if n_min is not None and n_min == n_max else "[]"
        return f"{item}{size}"
    if kind == "object":
        values = prop.get("additionalProperties")
        if isinstance(values, dict) and "$ref" in values:
            return f"{{NAME: {_type_text(values, defs)}}}"
        return "mapping"
    names = {
        "number": "float",
        "integer": "int",
        "string": "str",
        "boolean": "bool",
        "null": "null",
    }
    return names.get(kind, "any") if kind else "any"


def _range_text(prop: dict) -> str:
    for sub in prop.get("anyOf", []):  # `X | None`: the bounds are on X
        if "type" in sub and sub["type"] != "null":
            prop = {**sub, **prop}
    parts = []
    for key, sym in (("exclusiveMinimum", ">"), ("minimum", "≥")):
        if key in prop:
            parts.append(f"{sym} {prop[key]:g}")
    for key, sym in (("exclusiveMaximum", "<"), ("maximum", "≤")):
        if key in prop:
            parts.append(f"{sym} {prop[key]:g}")
    return ", ".join(parts)


def _table(rows: list[ParamRow]) -> list[str]:
    out = [
        "| key | type | unit | default | range | description |",
        "|---|---|---|---|---|---|",
    ]
    for r in rows:
        desc = r.description.replace("\n", " ").replace("|", "\\|")
        default = f"`{r.default}`" if r.default not in ("", "required", "see below") else r.default
        out.append(f"| `{r.name}` | {r.kind} | {r.unit} | {default} | {r.range} | {desc} |")
    return out


def _doc(cls: type) -> str:
    """The class docstring as paragraphs (indentation removed)."""
    text = (cls.__doc__ or "").strip()
    paras = [" ".join(p.split()) for p in re.split(r"\n\s*\n", text) if p.strip()]
    return "\n\n".join(paras)


def skill_markdown(cls: type[Skill], level: int = 2) -> str:
    """One skill's reference: description, parameters, outcomes, blackboard writes."""
    writes = cls.writes if isinstance(cls.writes, dict) else dict.fromkeys(cls.writes, "any")
    lines = [f"{'#' * level} `{cls.name}`", "", _doc(cls), ""]
    lines.append(
        "Outcomes: "
        + ", ".join(f"`{o}`" for o in cls.outcomes)
        + f" (success: `{cls.outcomes[0]}`)."
    )
    if writes:
        keys = ", ".join(f"the key named by `{f}` (a {t})" for f, t in writes.items())
        lines.append(f"Writes to the blackboard: {keys}.")
    lines += ["", *_table(param_rows(cls.Params)), ""]
    return "\n".join(lines)


def check_markdown(cls: type[SuccessCheck], level: int = 2) -> str:
    """One success check's reference: what it judges and its parameters (besides `kind`)."""
    lines = [f"{'#' * level} `{cls.kind}`", "", _doc(cls), ""]
    rows = [r for r in param_rows(cls.Params) if r.name != "kind"]
    example = {"kind": cls.kind} | {r.name: "..." for r in rows if r.default == "required"}
    shown = ", ".join(f"{k}: {v}" for k, v in example.items())
    lines += [f"In a scenario: `success: {{NAME: {{{shown}}}}}`.", ""]
    lines += [*_table(rows), ""] if rows else ["No parameters.", ""]
    return "\n".join(lines)


def guard_markdown(cls: type[Guard], level: int = 2) -> str:
    """One guard's reference: what it watches and its parameters."""
    lines = [f"{'#' * level} `{cls.name}`", "", _doc(cls), ""]
    rows = param_rows(cls.Params)
    lines += [*_table(rows), ""] if rows else ["No parameters.", ""]
    return "\n".join(lines)


_GENERATED = (
    "<!-- Generated from the code by `python -m orchestrator.language.reference`; "
    "tests/test_reference.py fails when it is stale. Do not edit by hand. -->"
)


def skills_reference() -> str:
    """docs/skills.md: every bundled skill and guard."""
    lines = [
        "# Skills and guards reference",
        "",
        _GENERATED,
        "",
        "A state runs a skill with `skill: NAME` and its parameters under `with:`; any parameter "
        "may be a blackboard read (`$key`). `orchestrator show skill NAME` prints the same "
        "page for one skill, including skills from plugins and `--skills` folders. How to "
        "write your own: [tutorial-first-flow.md](tutorial-first-flow.md).",
        "",
        "Skills: " + ", ".join(f"[`{n}`](#{n.replace('_', '_')})" for n in bundled_skill_names()),
        "",
    ]
    for name in bundled_skill_names():
        lines.append(skill_markdown(get_skill(name)))
    lines += [
        "# Guards",
        "",
        "Guards are listed under `guards:` of a machine, a state or a scenario "
        "(`[joint_limits, {contact_force: {max_n: 40}}]`) and checked every physics step; a "
        "violation aborts the run through the controlled stop.",
        "",
    ]
    for cls in bundled_guards().values():  # not a test's or a plugin's guard
        lines.append(guard_markdown(cls))
    lines += [
        "# Success checks",
        "",
        "A scenario's `success:` names checks judged once at the end of a run (`{placed: "
        "{kind: object_at, object: cube, target: $place_at}}`); a failing one makes the run "
        "`failed` and says by how much in `success_detail`. `orchestrator list checks` shows "
        "every kind, with plugins and `--skills` folders; how to write one: "
        "[success-checks.md](success-checks.md).",
        "",
    ]
    for kind in bundled_check_kinds():
        lines.append(check_markdown(CHECKS[kind]))
    return "\n".join(lines).rstrip() + "\n"


def scenario_reference() -> str:
    """docs/scenario-reference.md: every key of a scenario file, nested models as sections."""
    lines = [
        "# Scenario reference",
        "",
        _GENERATED,
        "",
        "A scenario is everything about an episode but its seed: the robot, the scene, the "
        "machine to run, the guards, what success means, physics and perception. Run it with "
        "`orchestrator run FILE`; `--set dotted.path=VALUE` overrides any key below "
        "(`--set physics.time_limit_s=10`). Units are SI unless the unit column says "
        "otherwise; `range` is what the validator accepts. The machine language itself is in "
        "[machine-language.md](machine-language.md).",
        "",
        "## Example",
        "",
        "```yaml",
        *_EXAMPLE.strip().splitlines(),
        "```",
        "",
    ]
    seen: set[type[BaseModel]] = set()
    queue: list[tuple[str, type[BaseModel]]] = [("", Scenario)]
    while queue:
        path, model = queue.pop(0)
        if model in seen:
            continue
        seen.add(model)
        rows = param_rows(model)
        title = f"`{path}`" if path else "Top level"
        lines += [f"## {title}", "", _doc(model) if model.__doc__ else "", ""]
        lines += [*_table(rows), ""]
        for r in rows:
            if r.model is CheckParams:  # one section per kind, in docs/skills.md
                lines += [
                    f"`{r.name}.NAME` is `{{kind: KIND, ...}}`: the keys of each kind are in "
                    "[skills.md](skills.md#success-checks) (bundled: "
                    + ", ".join(f"`{k}`" for k in bundled_check_kinds())
                    + ").",
                    "",
                ]
                continue
            if r.model is not None and r.model not in seen:
                sub = f"{path}.{r.name}" if path else r.name
                if "[]" in r.kind:
                    sub += "[]"
                elif "NAME" in r.kind:
                    sub += ".NAME"
                queue.append((sub, r.model))
    return "\n".join(line for line in lines).replace("\n\n\n", "\n\n").rstrip() + "\n"


_EXAMPLE = """
# yaml-language-server: $schema=scenario.schema.json  (orchestrator schema scenario > ...)
name: my_pick_place
description: Pick the cube and put it where --set place_at=[x, y, z] says.
machine: my_flow.yaml           # relative to this file, or a bundled machine name
skills: [my_skills]             # optional: a folder of your own skill modules
scene:
  table: {center_xy: [0.55, 0.0], size_xy: [0.7, 0.9], height: 0.2}
  objects:
    - name: cube
      size: [0.05, 0.05, 0.05]
      mass: 0.1
      xy: [0.5, -0.12]
      randomize: {x: [-0.05, 0.05], y: [-0.05, 0.05], yaw_deg: [-30, 30]}
  markers:
    - {name: pad, xy: [0.5, 0.2]}
blackboard: {place_at: pad}
guards:
  workspace: {min: [0.05, -0.6, 0.15], max: [0.95, 0.6, 1.2]}
  contact_force: {max_n: 60}
success:
  cube_placed: {kind: object_at, object: cube, target: $place_at, xy_tol_m: 0.01}
  gripper_clear: {kind: gripper_clear, object: cube}
physics: {time_limit_s: 20}
perception: {position_noise_m: 0.001}
"""


def write_reference_docs(docs_dir: Path = DOCS_DIR) -> list[Path]:
    """Regenerate docs/skills.md and docs/scenario-reference.md (after changing a model)."""
    pages = {"skills.md": skills_reference(), "scenario-reference.md": scenario_reference()}
    paths = []
    for name, text in pages.items():
        path = docs_dir / name
        path.write_text(text)
        paths.append(path)
    return paths


if __name__ == "__main__":
    for p in write_reference_docs():
        print(f"wrote {p}")


def _default_origins(machine: Any) -> dict[str, str]:
    """Key -> `machine NAME` whose default a run starts with, in the order `initial_values`
    applies them (nested machines first, so the outermost declaration wins)."""
    origin: dict[str, str] = {}

    def collect(node: Any) -> None:
        for child in node.children.values():
            collect(child)
        origin.update(dict.fromkeys(node.blackboard, f"machine `{node.name}`"))

    collect(machine)
    return origin


def scenario_summary(loaded: Any) -> str:
    """`orchestrator show scenario NAME`: what a scenario sets up and what it can be told.

    Args:
        loaded: A `LoadedScenario`.
    """
    from .inputs import machine_inputs
    from .loading import initial_values
    from .validation import blackboard_types

    scn = loaded.scenario
    machine = loaded.machine
    lines = [f"# scenario `{scn.name}` ({loaded.path})", ""]
    if scn.description:
        lines += [" ".join(scn.description.split()), ""]
    lines.append(f"Machine: `{machine.name}` (`orchestrator show machine {scn.machine}`).")
    lines.append(
        f"Robot: `{scn.robot.name}`" + (f" with tool `{scn.tool.name}`." if scn.tool else ".")
    )
    scene = [f"object `{o.name}` ({o.mass:g} kg)" for o in scn.scene.objects]
    scene += [f"marker `{m.name}` at {m.xy}" for m in scn.scene.markers]
    if scn.scene.phantom is not None:
        scene.append(f"phantom `{scn.scene.phantom.name}`")
    lines.append("Scene: " + (", ".join(scene) or "the table only") + ".")
    guards = (
        scn.guards
        if isinstance(scn.guards, dict)
        else {
            (g if isinstance(g, str) else next(iter(g))): None
            for g in scn.guards  # type: ignore[arg-type]
        }
    )
    lines.append("Guards: " + (", ".join(f"`{g}`" for g in guards) or "none") + ".")
    lines += ["", "## Blackboard (`--set KEY=VALUE`)", ""]
    lines += [
        "The values this scenario starts with: its own `blackboard:`, else the default of the "
        "outermost machine that declares the key (a nested machine's defaults give way to "
        "its parent's). Inputs may also be set by a live command or a planner (docs/live.md).",
        "",
        "| key | type | value | set by | input |",
        "|---|---|---|---|---|",
    ]
    types = blackboard_types(machine)
    inputs = machine_inputs(machine)
    values = initial_values(machine, scn.blackboard)
    origin = _default_origins(machine)
    origin.update(dict.fromkeys(scn.blackboard, "this scenario"))
    for key in sorted(types):
        value = _value(values[key]) if key in values else ""
        by = origin.get(key, "a skill writes it")
        live = "yes" if key in inputs else ""
        lines.append(f"| `{key}` | {types[key]} | {value} | {by} | {live} |")
    lines += ["", "## Success checks", ""]
    for name, check in scn.success.items():
        entry = check.model_dump() if isinstance(check, BaseModel) else dict(check)
        kind = entry.pop("kind", "?")
        given = ", ".join(f"{k} {_value(v)}" for k, v in entry.items())
        lines.append(f"* `{name}`: {kind}" + (f" ({given})" if given else ""))
    if not scn.success:
        lines.append("None: the machine's final outcome decides.")
    return "\n".join(lines) + "\n"
