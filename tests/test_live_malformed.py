"""Every malformed command is answered exactly once, by name (issue 39): lone surrogates
anywhere, huge integers, wrong types, and one message for a machine path whether it is
missing or outside the allowed folders. Against a real `serve` on 127.0.0.1."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from orchestrator.engine.snapshot.signing import KEY_ENV
from orchestrator.live.protocol import key

from .live_server import LiveServer

BIG = "9" * 400
TARGET = '"target=[0.5, 0.1, 0.4]"'


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    folder = tmp_path_factory.mktemp("malformed")
    with pytest.MonkeyPatch.context() as mp:
        mp.delenv(KEY_ENV, raising=False)
        mp.setenv("XDG_CONFIG_HOME", str(folder / "config"))
        srv = LiveServer(folder, name="malformed", speed=0.0)
        yield srv
        srv.close()


def _answers(server: LiveServer, payload: bytes) -> list[dict]:
    """Every reply to one query on `command` (the query ends when the session finalizes it)."""
    replies = server.z.get(key(server.name, "command"), payload=payload, timeout=20.0)
    return [json.loads(r.ok.payload.to_string()) for r in replies if r.ok is not None]


def _refused(server: LiveServer, payload: str | bytes) -> str:
    raw = payload.encode() if isinstance(payload, str) else payload
    answers = _answers(server, raw)
    assert len(answers) == 1, answers
    assert answers[0]["accepted"] is False, answers[0]
    assert "internal error" not in answers[0]["reason"]
    return answers[0]["reason"]


@pytest.mark.parametrize(
    ("payload", "named"),
    [
        ('{"op": "run", "machine": "reach", "set": [' + TARGET + ', "x=\\ud800"]}', "set[1]"),
        ('{"op": "run", "set": ["\\udfff=1"]}', "set[0]"),
        ('{"op": "status", "client": "a\\ud800b"}', "client"),
        ('{"op": "status", "\\ud800": 1}', "key"),
        ('{"op": "snapshot", "snapshot": "\\udc00"}', "snapshot"),
    ],
)
def test_a_lone_surrogate_anywhere_is_refused_by_name(server, payload, named):
    reason = _refused(server, payload)
    assert "lone surrogate" in reason and named in reason


@pytest.mark.parametrize(
    "payload",
    [
        '{"op": "run", "machine": "reach", "set": ["target=[' + BIG + ', 0.1, 0.4]"]}',
        '{"op": "run", "machine": "reach", "set": ["target=[0.5, -' + BIG + ', 0.4]"]}',
        '{"op": "status", "preempt": ' + "9" * 5000 + "}",
    ],
    ids=["x", "y", "preempt of 5000 digits"],
)
def test_a_huge_integer_is_out_of_range(server, payload):
    assert "out of range" in _refused(server, payload)


@pytest.mark.parametrize("value", ['"yes"', "1", '"true"', "null", BIG[:40]])
def test_preempt_must_be_a_boolean(server, value):
    reason = _refused(server, '{"op": "run", "machine": "home", "preempt": ' + value + "}")
    assert "preempt" in reason and "boolean" in reason


@pytest.mark.parametrize("value", ["null", "~", "[0.5, 0.1]", '"nowhere"', "true"])
def test_target_must_be_a_position(server, value):
    reason = _refused(server, json.dumps({"op": "run", "machine": "reach",
                                          "set": [f"target={value}"]}))  # fmt: skip
    assert "target" in reason


def test_a_machine_outside_the_allowed_folders_or_missing_gets_the_same_answer(server):
    outside = Path("/etc/hostname")
    assert outside.is_file()
    reasons = [
        _refused(server, json.dumps({"op": "run", "machine": ref})).replace(ref, "REF")
        for ref in (str(outside), "/etc/no-such-file.yaml", "../../../etc/hostname",
                    "/nowhere/at/all.yaml")
    ]  # fmt: skip
    assert len(set(reasons)) == 1, reasons
    assert "outside" not in reasons[0] and "not found" not in reasons[0]
    # a machine file in an allowed folder still loads (a reload needs a running task: none)
    reason = _refused(server, json.dumps({"op": "reload", "machine": str(outside)}))
    assert "no task is running" in reason


def test_the_session_still_answers_after_all_of_them(server):
    answers = _answers(server, b'{"op": "status"}')
    assert len(answers) == 1 and answers[0]["accepted"] and answers[0]["status"]["state"]


def test_a_reload_names_no_difference_between_outside_and_missing_while_a_task_runs():
    """`reload` checks its file only while a task runs (above it is refused before): then
    too, one answer for a file outside the allowed folders and one that does not exist."""
    from orchestrator.live.protocol import Command
    from orchestrator.live.session import Session

    session = Session("pick_place", "reload-refs", seed=3, speed=0.0)
    assert session.submit(Command(op="run")).accepted
    session._drain()
    session._start_next()
    session._tick()
    assert session.state == "MOVING"
    refs = ("/etc/hostname", "/etc/no-such-file.yaml", "../../../etc/hostname", "/etc")
    reasons = []
    for ref in refs:
        reply = session.submit(Command(op="reload", machine=ref))
        assert not reply.accepted
        reasons.append(reply.reason.replace(ref, "REF"))
    assert len(set(reasons)) == 1, reasons
    assert "outside" not in reasons[0] and "not found" not in reasons[0]
