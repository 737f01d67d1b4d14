"""The command channel's wire format: every payload is a `Command` or a named refusal."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from orchestrator.live.protocol import Command
from orchestrator.live.wire import MAX_COMMAND_BYTES, MAX_DEPTH, MalformedCommand, decode_command

from .live_attacks import CATEGORIES, malformed_payloads


def test_a_command_decodes_with_every_field():
    cmd = decode_command(
        b'{"op": "run", "machine": "reach", "set": ["target=[0.5, 0.1, 0.4]"], '
        b'"client": "me", "owner": "ab12", "preempt": true}'
    )
    assert cmd == Command(op="run", machine="reach", set=["target=[0.5, 0.1, 0.4]"],
                          client="me", owner="ab12", preempt=True)  # fmt: skip


@pytest.mark.parametrize(
    ("payload", "message"),
    [
        (None, "empty payload: a command is one JSON object"),
        (b"", "empty payload"),
        (b"x" * (MAX_COMMAND_BYTES + 1), f"too large: {MAX_COMMAND_BYTES + 1} bytes (limit "),
        (b'{"op": "st\xffatus"}', "not UTF-8: byte 0xff at offset 10"),
        (b'{"op": "status"', "not JSON: Expecting ',' delimiter at line 1 column 16"),
        (b'{"op": "status", "op": "estop"}', "duplicate key 'op': each key may appear once"),
        (b'{"op": "status", "set": [NaN]}', "not JSON: NaN is not a JSON number"),
        (b'{"op": "status", "set": [-Infinity]}', "not JSON: -Infinity is not a JSON number"),
        (b"[" * 40 + b"]" * 40, f"nested too deeply: more than {MAX_DEPTH} levels"),
        (b'["op", "status"]', "a command is one JSON object, not list"),
        (b'{"op": "jump"}', "op: Input should be 'run', 'stop', 'estop'"),
        (b'{"op": "status", "extra": 1}', "extra: Extra inputs are not permitted"),
        (b'{"op": "status", "\\u001b[31m": 1}', "'\\x1b[31m': Extra inputs are not permitted"),
        (b'{"op": "run", "owner": "' + b"o" * 129 + b'"}', "owner: String should have at most"),
    ],
)
def test_a_malformed_payload_is_refused_with_the_problem_named(payload, message):
    with pytest.raises(MalformedCommand) as exc:
        decode_command(payload)
    assert message in str(exc.value)


def test_a_deep_payload_is_refused_before_the_parser_recurses():
    deep = b'{"op": "status", "set": ' + b"[" * 30_000 + b"]" * 30_000 + b"}"
    with pytest.raises(MalformedCommand, match="nested too deeply"):
        decode_command(deep[:MAX_COMMAND_BYTES])  # truncated as well: the depth comes first
    brackets_in_a_string = b'{"op": "status", "client": "' + b"[" * 100 + b'"}'
    assert decode_command(brackets_in_a_string).client == "[" * 100


def test_a_refusal_quotes_a_made_up_key_short_and_printable():
    with pytest.raises(MalformedCommand) as exc:
        decode_command(b'{"op": "status", "' + b"k\\n" * 500 + b'": 1}')
    text = str(exc.value)
    assert (
        len(text) < 200
        and "\n" not in text
        and text.endswith("...: Extra inputs are not permitted")
    )


def test_every_generated_attack_payload_is_refused():
    payloads = malformed_payloads(400, seed=7)
    assert {c for c, _ in payloads} == set(CATEGORIES)
    for category, payload in payloads:
        with pytest.raises(MalformedCommand):
            decode_command(payload)
        assert category  # each category was tried


@settings(max_examples=300, deadline=None)
@given(st.binary(max_size=300))
def test_no_byte_string_raises_anything_but_a_refusal(payload):
    try:
        cmd = decode_command(payload)
    except MalformedCommand as exc:
        assert str(exc)
    else:
        assert isinstance(cmd, Command)
