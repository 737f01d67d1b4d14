"""The blackboard: named values shared by the states of a run, read with `$key` in YAML."""

from __future__ import annotations

import re
from collections.abc import Mapping
from typing import Any

from pydantic import BaseModel

from .exceptions import OrchestratorError

__all__ = ["REF_PATTERN", "Blackboard", "BlackboardError", "parse_ref"]

REF_PATTERN = re.compile(r"^\$([A-Za-z_][A-Za-z0-9_]*)((?:\.[A-Za-z_][A-Za-z0-9_]*|\[\d+\])*)$")


class BlackboardError(OrchestratorError):
    """A `$key` reference could not be resolved."""


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


class Blackboard:
    """Key -> value store of one run."""

    def __init__(self, values: Mapping[str, Any] | None = None) -> None:
        self._values: dict[str, Any] = dict(values or {})

    def __contains__(self, key: str) -> bool:
        return key in self._values

    def __getitem__(self, key: str) -> Any:
        try:
            return self._values[key]
        except KeyError:
            valid = ", ".join(sorted(self._values)) or "none"
            raise BlackboardError(f"no blackboard key {key!r} (valid: {valid})") from None

    def __setitem__(self, key: str, value: Any) -> None:
        self._values[key] = value

    def get(self, key: str, default: Any = None) -> Any:
        return self._values.get(key, default)

    def as_dict(self) -> dict[str, Any]:
        return dict(self._values)

    def resolve(self, value: Any) -> Any:
        """Replace every `$key`, `$key.field` and `$key[i]` in `value` by its current value."""
        ref = parse_ref(value)
        if ref is not None:
            key, rest = ref
            out = self[key]
            for part in rest:
                out = _index(out, part, value)
            return out
        if isinstance(value, dict):
            return {k: self.resolve(v) for k, v in value.items()}
        if isinstance(value, list):
            return [self.resolve(v) for v in value]
        return value


def _index(obj: Any, part: str | int, ref: str) -> Any:
    try:
        if isinstance(part, int):
            return obj[part]
        if isinstance(obj, BaseModel):
            return getattr(obj, part)
        return obj[part]
    except (KeyError, IndexError, TypeError, AttributeError):
        raise BlackboardError(f"{ref}: cannot read {part!r} of {obj!r}") from None
