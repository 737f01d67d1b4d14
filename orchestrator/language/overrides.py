"""`--set KEY=VALUE`: override a blackboard key or any scenario value by its dotted path."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from ..exceptions import ConfigError
from .diagnostics import Diagnostic, did_you_mean
from .yamlio import parse_yaml

__all__ = ["Override", "apply_override", "parcels_alias", "parse_override"]


@dataclass(frozen=True)
class Override:
    """One `--set`: `path` is dotted (`guards.workspace.max`), `value` parsed as YAML."""

    text: str
    path: tuple[str, ...]
    value: Any

    def diag(self, message: str, valid: tuple[str, ...] = ()) -> Diagnostic:
        return Diagnostic("<--set>", 0, 0, ".".join(self.path) or self.text, message, valid)


def parse_override(text: str) -> Override | Diagnostic:
    """Parse `KEY=VALUE`; the value is YAML (`0.5`, `[0.8, 0.3, 0.9]`, `cube`)."""
    key, sep, raw = text.partition("=")
    key = key.strip()
    if not sep or not key:
        return Diagnostic(
            "<--set>", 0, 0, text, "expected KEY=VALUE, e.g. --set place_at=[0.5,0.2,0.3]"
        )
    if not raw.strip():
        return Override(text, tuple(key.split(".")), "")
    try:  # the loader of the files, with their caps: no tags, huge integers or alias bombs
        value = parse_yaml(raw, "<--set>").data
    except ConfigError as exc:
        why = "; ".join(d.message for d in exc.diagnostics)
        return Diagnostic("<--set>", 0, 0, key, f"cannot read value {raw!r}: {why}")
    return Override(text, tuple(key.split(".")), value)


def parcels_alias(data: dict, ov: Override) -> tuple[str, ...] | None:
    """Where `parcels=N` writes in this scenario: `scene.parcels.count` in a bin-picking cell,
    `scene.conveyor.parcels` in a conveyor cell; None for any other override or scene."""
    scene = data.get("scene")
    if ov.path != ("parcels",) or not isinstance(scene, dict):
        return None
    if isinstance(scene.get("parcels"), dict):
        return ("scene", "parcels", "count")
    if isinstance(scene.get("conveyor"), dict):
        return ("scene", "conveyor", "parcels")
    return None


def apply_override(data: dict, ov: Override, blackboard_keys: set[str]) -> Diagnostic | None:
    """Apply `ov` to the raw scenario mapping `data` in place. `parcels=N` is short for
    `scene.parcels.count=N` (`scene.conveyor.parcels=N` in a conveyor cell)."""
    alias = parcels_alias(data, ov)
    if alias is not None:
        data[alias[0]][alias[1]][alias[2]] = ov.value
        return None
    if len(ov.path) == 1 and ov.path[0] not in data and ov.path[0] not in _SCENARIO_KEYS:
        key = ov.path[0]
        if key not in blackboard_keys:
            valid = tuple(sorted(blackboard_keys | set(_SCENARIO_KEYS)))
            return ov.diag(
                "not a blackboard key of this machine nor a scenario key"
                + did_you_mean(key, valid),
                valid,
            )
        data.setdefault("blackboard", {})[key] = ov.value
        return None
    node: Any = data
    for i, part in enumerate(ov.path):
        last = i == len(ov.path) - 1
        if isinstance(node, list):
            idx = _list_index(node, part)
            if idx is None:
                names = [str(j) for j in range(len(node))] + [
                    n for n in (_item_name(x) for x in node) if n
                ]
                return ov.diag(f"no item {part!r} in the list", tuple(names))
            if last:
                node[idx] = ov.value
                return None
            item = node[idx]
            if isinstance(item, str):  # bare guard name -> {name: {}}
                item = node[idx] = {item: {}}
            if isinstance(item, dict) and len(item) == 1 and part in item:
                if item[part] is None:
                    item[part] = {}
                node = item[part]
            else:
                node = item
            continue
        if not isinstance(node, dict):
            return ov.diag(f"cannot set {part!r} inside a {type(node).__name__}")
        if last:
            node[part] = ov.value
            return None
        if part not in node or node[part] is None:
            node[part] = {}
        node = node[part]
    return None


_SCENARIO_KEYS = (
    "name",
    "description",
    "robot",
    "scene",
    "machine",
    "blackboard",
    "guards",
    "success",
    "physics",
    "perception",
    "randomize",
)


def _item_name(item: Any) -> str | None:
    if isinstance(item, str):
        return item
    if isinstance(item, dict):
        if "name" in item:
            return str(item["name"])
        if len(item) == 1:
            return str(next(iter(item)))
    return None


def _list_index(items: list, part: str) -> int | None:
    if part.isdigit():
        i = int(part)
        return i if i < len(items) else None
    for i, item in enumerate(items):
        if _item_name(item) == part:
            return i
    return None
