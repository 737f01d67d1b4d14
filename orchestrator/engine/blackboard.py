"""The blackboard: named values shared by the states of a run, read with `$key` in YAML."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from pydantic import BaseModel

from ..exceptions import OrchestratorError
from ..language.refs import parse_ref

__all__ = ["Blackboard", "BlackboardError"]


class BlackboardError(OrchestratorError):
    """A `$key` reference could not be resolved."""


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
        """The value of `key`, or `default` if nothing wrote it (`ctx.blackboard[key]` reads
        one that must be there: a missing key is an error naming the keys there are;
        `ctx.blackboard[key] = value` writes one)."""
        return self._values.get(key, default)

    def as_dict(self) -> dict[str, Any]:
        """A copy of every key and its value."""
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
