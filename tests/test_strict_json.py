"""Every JSON the project prints or writes is strict JSON: a non-finite number is `null`, never
`NaN` or `Infinity` (which `jq`, JavaScript and most parsers refuse). Each command's producer is
replaced by one that returns NaN and infinities, and what the command prints is parsed with a
parser that raises on them."""

from __future__ import annotations

import json
import math
from types import SimpleNamespace

import pytest

from orchestrator.batch.store import ResultsStore
from orchestrator.engine.result import RunResult
from orchestrator.engine.strict_json import dumps, strict

NAN, INF = math.nan, math.inf


def _refuse(constant: str) -> None:
    raise ValueError(f"not strict JSON: {constant}")


def strict_loads(text: str):
    """`json.loads` that refuses NaN, Infinity and -Infinity."""
    return json.loads(text, parse_constant=_refuse)


def test_strict_replaces_every_non_finite_number_at_any_depth():
    value = {"a": NAN, "b": [1.0, INF, {"c": -INF, "d": (NAN, 2)}], "e": "NaN", "f": 3}
    assert strict(value) == {"a": None, "b": [1.0, None, {"c": None, "d": [None, 2]}],
                             "e": "NaN", "f": 3}  # fmt: skip
    assert strict_loads(dumps(value))["b"][2]["c"] is None
    with pytest.raises(ValueError, match="not strict JSON: NaN"):
        strict_loads(json.dumps(value))  # the parser used below does refuse NaN


def _result() -> RunResult:
    return RunResult(
        scenario="s", seed=0, outcome="succeeded", final_state="DONE", sim_time=NAN,
        wall_time=INF, transitions=[], metrics={"tcp_error_mm": NAN, "x": [INF]}, success={},
    )  # fmt: skip


def test_run_json(cli, monkeypatch):
    monkeypatch.setattr(
        "orchestrator.engine.prepare.Prepared.run_episode", lambda *a, **k: _result()
    )
    res = cli("run", "pick_place", "--json")
    assert res.exit_code == 0, res.stderr
    line = strict_loads(res.stdout)
    assert line["sim_time"] is None and line["metrics"] == {"tcp_error_mm": None, "x": [None]}


def test_faults_json(cli, monkeypatch):
    row = SimpleNamespace(
        ok=True, blind=False, fault="estop@1", to_dict=lambda: {"fault": "estop@1", "detect_s": NAN}
    )
    monkeypatch.setattr("orchestrator.batch.fault_matrix.run_matrix", lambda *a, **k: [row])
    res = cli("faults", "pick_place", "--json")
    assert res.exit_code == 0, res.stderr
    assert strict_loads(res.stdout) == [{"fault": "estop@1", "detect_s": None}]


def test_batch_json_and_its_files(cli, monkeypatch, tmp_path):
    summary = SimpleNamespace(errors=0, to_json_dict=lambda: {"success_rate": NAN, "p": [INF]})
    monkeypatch.setattr("orchestrator.batch.run_batch", lambda *a, **k: summary)
    res = cli("batch", "pick_place", "-n", "1", "--out", str(tmp_path / "b"), "--json")
    assert res.exit_code == 0, res.stderr
    assert strict_loads(res.stdout) == {"success_rate": None, "p": [None]}
    store = ResultsStore(tmp_path / "r")
    store.open()
    store.append(_result().to_json_dict())
    store.close()
    assert strict_loads(store.path.read_text())["wall_time"] is None


class _FakeClient:
    """Stands in for `orchestrator.live.client.Client`: answers with non-finite numbers."""

    def __init__(self, *args, **kwargs) -> None:
        pass

    def __enter__(self) -> _FakeClient:
        return self

    def __exit__(self, *exc) -> None:
        pass

    def run(self, machine, sets, wait=False, preempt=False):
        result = {"task": "e0-1", "machine": machine, "outcome": "succeeded", "exit_code": 0,
                  "final_state": "DONE", "sim_time": NAN,
                  "metrics": {"tcp_error_mm": INF}}  # fmt: skip
        return SimpleNamespace(accepted=True, task="e0-1"), result


def test_send_json(cli, monkeypatch):
    monkeypatch.setattr("orchestrator.live.client.Client", _FakeClient)
    res = cli("send", "cell", "run", "reach", "--wait", "--json")
    assert res.exit_code == 0, res.stderr
    assert strict_loads(res.stdout)["metrics"] == {"tcp_error_mm": None}


def test_ask_json(cli, monkeypatch):
    # a planner's reply is parsed with Python's json, which reads a bare NaN: once printed back
    reply = SimpleNamespace(
        accepted=True, task=1, model_dump=lambda mode=None: {"accepted": True, "v": NAN}
    )
    proposal = {"machine": "reach", "set": {"target": [NAN, 0.0, INF]}}
    monkeypatch.setenv("ORCHESTRATOR_PLANNER_URL", "http://127.0.0.1:9/v1")
    monkeypatch.setattr("orchestrator.live.client.Client", _FakeClient)
    monkeypatch.setattr(
        "orchestrator.live.planner.ask_planner", lambda *a, **k: (proposal, reply, None)
    )
    res = cli("ask", "cell", "go", "--json")
    assert res.exit_code == 0, res.stderr
    out = strict_loads(res.stdout)
    assert out["proposal"]["set"]["target"] == [None, 0.0, None]
    assert out["reply"] == {"accepted": True, "v": None}
