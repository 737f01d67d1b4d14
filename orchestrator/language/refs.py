"""Blackboard references: `$key`, `$key.field`, `$key[i]` in YAML values."""

from __future__ import annotations

import re
from typing import Any

__all__ = ["REF_PATTERN", "parse_ref"]

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
