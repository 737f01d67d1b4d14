"""Blackboard references: `$key`, `$key.field`, `$key[i]` in YAML values."""

from __future__ import annotations

import re
from collections.abc import Iterator
from typing import Any

__all__ = ["REF_PATTERN", "has_ref", "iter_refs", "parse_ref", "ref_type"]

REF_PATTERN = re.compile(r"^\$([A-Za-z_][A-Za-z0-9_]*)((?:\.[A-Za-z_][A-Za-z0-9_]*|\[\d+\])*)$")


def parse_ref(value: Any) -> tuple[str, list[str | int]] | None:
    """`"$pose.pos[2]"` -> `("pose", ["pos", 2])`; anything else -> None."""
    if not isinstance(value, str):
        return None
    match = REF_PATTERN.match(value)
    if not match:
        return None
    rest: list[str | int] = []
    for part in re.findall(r"\.([A-Za-z_][A-Za-z0-9_]*)|\[(\d+)\]", match.group(2)):
        rest.append(part[0] if part[0] else int(part[1]))
    return match.group(1), rest


def iter_refs(value: Any, path: tuple) -> Iterator[tuple[tuple, str, list]]:
    """Every `$key...` read in a value: (path of the read, key, parts after it); a malformed
    one (`$1x`) as (path, the text, [])."""
    ref = parse_ref(value)
    if ref is not None:
        yield path, ref[0], ref[1]
    elif isinstance(value, dict):
        for k, v in value.items():
            yield from iter_refs(v, (*path, k))
    elif isinstance(value, list):
        for i, v in enumerate(value):
            yield from iter_refs(v, (*path, i))
    elif isinstance(value, str) and value.startswith("$"):
        yield path, value, []  # malformed reference


def has_ref(value: Any) -> bool:
    """`value` holds a `$key` read anywhere."""
    return any(True for _ in iter_refs(value, ()))


_STEPS: dict[str, dict[str | int, str]] = {
    "pose": {"pos": "vec3", "quat": "quat"},
    "vec3": {0: "float", 1: "float", 2: "float"},
    "quat": {0: "float", 1: "float", 2: "float", 3: "float"},
}
"""What a `.field` or `[i]` read of a value of each structured type gives."""


def ref_type(type_: str, rest: list[str | int], key: str) -> tuple[str | None, str | None]:
    """The type a `$key.field[i]` read gives, from the key's `type_` and the parts after it.

    Returns:
        (type, problem): the type read (None when it cannot be known: `any`, `list`, `dict`),
        or a problem naming the first part that cannot be read, with the ones that can.
    """
    shown = f"${key}"  # then each part, as it is read
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
