"""The command channel's wire format: a payload's bytes in, a `Command` or a named refusal out.

A session takes payloads from anyone who can reach its key, so `decode_command` trusts
nothing: the size is bounded before anything is decoded, the text must be UTF-8, the JSON
must be one object without duplicate keys (`{"op": "status", "op": "estop"}` is refused, not
read as its last key), without `NaN`/`Infinity`, nested no deeper than `MAX_DEPTH`, and then
it must fit `Command` (pydantic, unknown fields refused). Every way to fail raises
`MalformedCommand` with the problem named; nothing else escapes.
"""

from __future__ import annotations

import json
from typing import Any

from pydantic import ValidationError

from .protocol import Command

__all__ = ["MAX_COMMAND_BYTES", "MAX_DEPTH", "MalformedCommand", "decode_command", "quote"]

MAX_COMMAND_BYTES = 65_536
"""Largest payload decoded [bytes]; a command is a few hundred bytes."""
MAX_DEPTH = 16
"""Deepest nesting of JSON arrays and objects a command may have (it needs 2)."""
_QUOTE_CHARS = 60


class MalformedCommand(ValueError):
    """A payload is not a command: the message names the problem (never echoes it whole)."""


def quote(text: str) -> str:
    """`text` as a short, printable quotation: control characters escaped, cut at 60."""
    shown = repr(text[:_QUOTE_CHARS])
    return shown + ("..." if len(text) > _QUOTE_CHARS else "")


def _loc(part: str | int) -> str:
    """A field name as it is when it is a name, quoted when a client made it up."""
    text = str(part)
    return text if text.isidentifier() and len(text) <= _QUOTE_CHARS else quote(text)


def _no_duplicates(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    seen: set[str] = set()
    for k, _ in pairs:
        if k in seen:
            raise MalformedCommand(f"duplicate key {quote(k)}: each key may appear once")
        seen.add(k)
    return dict(pairs)


def _no_constant(name: str) -> Any:
    raise MalformedCommand(f"not JSON: {name} is not a JSON number")


def _depth(text: str) -> int:
    """The deepest nesting of `[`/`{` outside strings (so a deep payload is refused before
    the parser recurses into it)."""
    if text.count("[") + text.count("{") <= MAX_DEPTH:  # every command: no scan needed
        return 0
    depth = deepest = 0
    in_string = escaped = False
    for ch in text:
        if in_string:
            if escaped:
                escaped = False
            elif ch == "\\":
                escaped = True
            elif ch == '"':
                in_string = False
        elif ch == '"':
            in_string = True
        elif ch in "[{":
            depth += 1
            if depth > deepest:
                deepest = depth
                if deepest > MAX_DEPTH:
                    break
        elif ch in "]}":
            depth -= 1
    return deepest


def _no_surrogates(value: Any, where: str) -> None:
    """Refuse a lone UTF-16 surrogate (`\\ud800` in JSON) in any key or string: it is no
    character, and no answer that quotes it could be encoded."""
    if isinstance(value, str):
        try:
            value.encode("utf-8")
        except UnicodeEncodeError as exc:
            code = ord(value[exc.start])
            raise MalformedCommand(
                f"{where or 'command'}: lone surrogate U+{code:04X} at character {exc.start}: "
                "text must be valid Unicode (surrogates only come in pairs)"
            ) from None
    elif isinstance(value, dict):
        for k, v in value.items():
            _no_surrogates(k, f"{where + '.' if where else ''}key")
            _no_surrogates(v, f"{where + '.' if where else ''}{_loc(k) if _utf8(k) else 'key'}")
    elif isinstance(value, list):
        for i, v in enumerate(value):
            _no_surrogates(v, f"{where}[{i}]")


def _utf8(text: str) -> bool:
    try:
        text.encode("utf-8")
    except UnicodeEncodeError:
        return False
    return True


def decode_command(payload: bytes | None) -> Command:
    """Decode one command payload.

    Args:
        payload: The query's payload (None: the query had none).

    Returns:
        The command, validated.

    Raises:
        MalformedCommand: Empty, too large, not UTF-8, not JSON, not one object, a duplicate
            key, too deep, or not a `Command` (unknown op, unknown field, wrong type).
    """
    if not payload:
        raise MalformedCommand('empty payload: a command is one JSON object, e.g. {"op": "status"}')
    if len(payload) > MAX_COMMAND_BYTES:
        raise MalformedCommand(f"too large: {len(payload)} bytes (limit {MAX_COMMAND_BYTES})")
    try:
        text = payload.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise MalformedCommand(
            f"not UTF-8: byte 0x{payload[exc.start]:02x} at offset {exc.start}"
        ) from None
    depth = _depth(text)
    if depth > MAX_DEPTH:
        raise MalformedCommand(f"nested too deeply: more than {MAX_DEPTH} levels")
    try:
        obj = json.loads(text, object_pairs_hook=_no_duplicates, parse_constant=_no_constant)
    except json.JSONDecodeError as exc:
        raise MalformedCommand(
            f"not JSON: {exc.msg} at line {exc.lineno} column {exc.colno}"
        ) from None
    except RecursionError:  # the depth scan makes this unreachable; kept as a last line
        raise MalformedCommand(f"nested too deeply: more than {MAX_DEPTH} levels") from None
    except MalformedCommand:  # a duplicate key, NaN: named where it was found
        raise
    except ValueError:  # Python's own cap on the digits of an integer (4300)
        raise MalformedCommand("a number is out of range: too many digits") from None
    if not isinstance(obj, dict):
        raise MalformedCommand(
            f'a command is one JSON object, not {type(obj).__name__}: e.g. {{"op": "status"}}'
        )
    _no_surrogates(obj, "")
    try:
        return Command.model_validate(obj)
    except ValidationError as exc:
        problems = "; ".join(
            f"{'.'.join(map(_loc, e['loc']))}: {e['msg']}" if e["loc"] else e["msg"]
            for e in exc.errors(include_url=False)
        )
        raise MalformedCommand(problems) from None
