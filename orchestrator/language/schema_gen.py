"""JSON Schemas (draft 7, for yaml-language-server) of the machine and scenario languages,
generated from the pydantic models, with each skill's `with:` and each guard's parameters.

The shipped files (orchestrator/schemas/) know the bundled skills only; `orchestrator schema`
also includes installed plugins and `--skills` folders, for an editor pointed at its output."""

from __future__ import annotations

import copy
import json
from pathlib import Path
from typing import Any

from pydantic import BaseModel

from ..guards import GUARDS, bundled_guards
from ..skills import bundled_skill_names, get_skill, skill_names
from ..success import CHECKS, bundled_check_kinds, check_kinds
from .machine import MachineSpec
from .scenario import Scenario

__all__ = ["SCHEMA_DIR", "machine_schema", "scenario_schema", "schema_text", "write_schemas"]

SCHEMA_DIR = Path(__file__).resolve().parent.parent / "schemas"
"""Where the generated schemas ship (package data `orchestrator.schemas`)."""
DRAFT7 = "http://json-schema.org/draft-07/schema#"
REF = "#/definitions/{model}"
REF_PATTERN = r"^\$[A-Za-z_][A-Za-z0-9_]*((\.[A-Za-z_][A-Za-z0-9_]*)|(\[[0-9]+\]))*$"
BLACKBOARD_REF = {"type": "string", "pattern": REF_PATTERN, "description": "A blackboard read."}


def _model_schema(model: type[BaseModel], defs: dict[str, Any], prefix: str = "") -> dict:
    """The model's schema; its sub-definitions go into `defs` (names prefixed to stay unique)."""
    schema = model.model_json_schema(ref_template="#/definitions/" + prefix + "{model}")
    for name, sub in schema.pop("$defs", {}).items():
        defs[prefix + name] = sub
    return schema


def _allow_refs(params: dict) -> dict:
    """Every parameter may also be a `$key` blackboard read (and so may list items)."""
    params = copy.deepcopy(params)
    for prop, sub in params.get("properties", {}).items():
        if sub.get("type") == "array" and isinstance(sub.get("items"), dict):
            sub["items"] = {"anyOf": [sub["items"], BLACKBOARD_REF]}
        params["properties"][prop] = {
            "anyOf": [sub, BLACKBOARD_REF],
            "description": sub.get("description", ""),
        }
    params.pop("required", None)  # a required parameter may come from the blackboard at run time
    return params


def _guard_schema(defs: dict[str, Any], bundled_only: bool = False) -> dict:
    guards = bundled_guards() if bundled_only else dict(sorted(GUARDS.items()))
    by_name = {}
    for name, cls in guards.items():
        by_name[name] = _model_schema(cls.Params, defs, prefix=f"guard_{name}_")
    one = {
        "type": "object",
        "minProperties": 1,
        "maxProperties": 1,
        "additionalProperties": False,
        "properties": {n: {"anyOf": [s, {"type": "null"}]} for n, s in by_name.items()},
    }
    return {"anyOf": [{"type": "string", "enum": sorted(guards)}, one]}


def _success_schema(defs: dict[str, Any], bundled_only: bool = False) -> dict:
    """`success:`: named checks, each `{kind: KIND, ...}` with that kind's parameters."""
    kinds = bundled_check_kinds() if bundled_only else check_kinds()
    entries = []
    for kind in kinds:
        params = _model_schema(CHECKS[kind].Params, defs, prefix=f"check_{kind}_")
        params["properties"]["kind"] = {"const": kind, "description": "Which check."}
        params["required"] = ["kind", *(r for r in params.get("required", []) if r != "kind")]
        entries.append(params)
    return {
        "type": "object",
        "description": "Named checks judged at the end of the run; any failing one makes it "
        "`failed`.",
        "additionalProperties": {"anyOf": entries},
    }


def _skill_conditions(defs: dict[str, Any], names: list[str]) -> list[dict]:
    conditions = []
    for name in names:
        prefix = f"skill_{name}_"
        params = _allow_refs(_model_schema(get_skill(name).Params, defs, prefix=prefix))
        for sub in [d for d in defs if d.startswith(prefix)]:  # nested models, e.g. via points
            defs[sub] = _allow_refs(defs[sub])
        conditions.append(
            {
                "if": {"properties": {"skill": {"const": name}}, "required": ["skill"]},
                "then": {"properties": {"with": params}},
            }
        )
    return conditions


def machine_schema(bundled_only: bool = False) -> dict:
    """JSON Schema of a machine file (with every available skill, or the bundled ones only)."""
    names = bundled_skill_names() if bundled_only else skill_names()
    defs: dict[str, Any] = {}
    schema = _model_schema(MachineSpec, defs)
    guard = _guard_schema(defs, bundled_only)
    conditions = _skill_conditions(defs, names)
    skills = {"type": "string", "enum": names, "description": "Skill to run."}
    for name in ("StateSpec", "BranchSpec"):
        spec = defs[name]
        spec["properties"]["skill"] = {"anyOf": [skills, {"type": "null"}]}
        spec["allOf"] = conditions
        if "guards" in spec["properties"]:
            spec["properties"]["guards"] = {"type": "array", "items": guard}
    schema["properties"]["guards"] = {"type": "array", "items": guard}
    return _finish(schema, defs, "embodied-orchestrator machine")


def scenario_schema(bundled_only: bool = False) -> dict:
    """JSON Schema of a scenario file."""
    defs: dict[str, Any] = {}
    schema = _model_schema(Scenario, defs)
    guard = _guard_schema(defs, bundled_only)
    mapping = {
        "type": "object",
        "additionalProperties": False,
        "properties": guard["anyOf"][1]["properties"],
    }
    schema["properties"]["guards"] = {"anyOf": [{"type": "array", "items": guard}, mapping]}
    schema["properties"]["success"] = _success_schema(defs, bundled_only)
    defs.pop("CheckParams", None)  # the model's own placeholder for an entry
    return _finish(schema, defs, "embodied-orchestrator scenario")


def _finish(schema: dict, defs: dict, title: str) -> dict:
    schema["title"] = title
    out = {"$schema": DRAFT7, **schema, "definitions": dict(sorted(defs.items()))}
    return out


def schema_text(kind: str, bundled_only: bool = False) -> str:
    """The schema of `machine` or `scenario` as formatted JSON (`bundled_only`: as shipped,
    without installed plugins or local skills)."""
    schema = machine_schema(bundled_only) if kind == "machine" else scenario_schema(bundled_only)
    return json.dumps(schema, indent=2, sort_keys=False) + "\n"


def write_schemas() -> list[Path]:
    """Regenerate the files in orchestrator/schemas/ (run after changing a model or skill)."""
    paths = []
    for kind in ("machine", "scenario"):
        path = SCHEMA_DIR / f"{kind}.schema.json"
        path.write_text(schema_text(kind, bundled_only=True))
        paths.append(path)
    return paths


if __name__ == "__main__":
    for p in write_schemas():
        print(f"wrote {p}")
