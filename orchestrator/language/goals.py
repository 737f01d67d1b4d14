"""The blackboard keys a machine moves to, read from its skills' parameter declarations.

Apart from the scenario checks: validating a machine (`check_inputs`) needs these and no
scenario model (docs/performance.md, "Start-up").
"""

from __future__ import annotations

import typing
from typing import Any

from pydantic import BaseModel

from ..skills import find_skill
from .loading import MachineNode
from .refs import parse_ref

__all__ = ["goal_keys", "item_model"]


def goal_keys(machine: MachineNode) -> set[str]:
    """Blackboard keys the machine moves to: those a skill's target parameter (a `target`,
    e.g. `move`'s, or a `via` point's) reads as `$key` anywhere in the tree. Offsets and
    heights are not goals."""
    keys: set[str] = set()

    def scan(model, params: dict) -> None:
        for field, info in model.model_fields.items():
            value = params.get(field)
            nested = item_model(info.annotation)
            if nested is not None:  # a list of parameter models: `move`'s `via` points
                for item in value if isinstance(value, list) else []:
                    if isinstance(item, dict):
                        scan(nested, item)
                continue
            extra = info.json_schema_extra
            if not isinstance(extra, dict) or extra.get("scene_ref") != "target":
                continue
            for item in value if isinstance(value, list) else [value]:
                ref = parse_ref(item)
                if ref is not None and not ref[1]:
                    keys.add(ref[0])

    for node in machine.nodes():
        for st in node.states.values():
            cls = find_skill(st.skill or "")
            if cls is not None:
                scan(cls.Params, st.with_)
        for _, _, br in node.skill_branches():
            cls = find_skill(br.skill or "")
            if cls is not None:
                scan(cls.Params, br.with_)
    return keys


def item_model(annotation: Any) -> type[BaseModel] | None:
    """The model of a `list[Model]` parameter's items (None for any other annotation)."""
    if typing.get_origin(annotation) is list:
        (item,) = typing.get_args(annotation) or (None,)
        if isinstance(item, type) and issubclass(item, BaseModel):
            return item
    return None
