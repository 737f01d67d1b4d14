"""The executor, ticked step by step with scripted skills (no physics)."""

from __future__ import annotations

from pathlib import Path

import pytest

from orchestrator.engine.executor import Executor
from orchestrator.engine.runner import initial_blackboard
from orchestrator.language.load import load_machine

from .scripted import FakeContext, InstantStop, Scripted, register


@pytest.fixture(autouse=True)
def _scripted(monkeypatch):
    from orchestrator.skills import SKILLS

    from orchestrator.guards import GUARDS

    monkeypatch.setattr("orchestrator.skills.registry.SKILLS", SKILLS)
    register()
    Scripted.stopped.clear()
    yield
    SKILLS.pop("scripted", None)
    GUARDS.pop("flag", None)


def _machine(tmp_path: Path, text: str, name: str = "m.yaml"):
    path = tmp_path / name
    path.write_text(text)
    return load_machine(str(path))


class Driver:
    """Ticks an executor on a fake clock."""

    def __init__(self, node, **bb):
        self.ctx = FakeContext()
        self.ctx.blackboard = initial_blackboard(node, bb)
        self.ex = Executor(node, self.ctx, [], InstantStop, hold_s=0.05)
        self.ex.start()

    def tick(self, n: int = 1) -> str:
        for _ in range(n):
            self.ex.tick()
            self.ctx.t = round(self.ctx.t + self.ctx.dt_control, 9)
        return self.ex.leaf

    def run(self, max_ticks: int = 1000) -> None:
        for _ in range(max_ticks):
            if self.ex.done:
                return
            self.tick()
        raise AssertionError("did not finish")

    @property
    def path(self) -> list[str]:
        return [t["to"] for t in self.ex.transitions]


SEQUENCE = """\
name: seq
initial: A
states:
  A:
    skill: scripted
    with: {ticks: 3}
    transitions: {done: B, failed: FAILED, other: FAILED}
  B:
    skill: scripted
    with: {ticks: 2}
    transitions: {done: DONE, failed: FAILED, other: FAILED}
  DONE: {final: succeeded}
  FAILED: {final: failed}
"""


def test_states_advance_on_outcomes_tick_by_tick(tmp_path):
    d = Driver(_machine(tmp_path, SEQUENCE))
    assert d.ex.leaf == "A"
    assert d.tick() == "A" and d.tick() == "A"
    assert d.tick() == "B"  # third tick: A returns done
    assert d.tick() == "B"
    d.tick()
    assert d.ex.done and d.ex.outcome == "succeeded" and d.ex.final_state == "DONE"
    assert [(t["from"], t["to"], t["trigger"]) for t in d.ex.transitions] == [
        ("A", "B", "done"),
        ("B", "DONE", "done"),
    ]


def test_timeout_ends_the_state_on_simulated_time(tmp_path):
    text = SEQUENCE.replace(
        "    with: {ticks: 3}\n", "    with: {ticks: 1000}\n    timeout: 0.05\n"
    )
    text = text.replace(
        "transitions: {done: B, failed: FAILED, other: FAILED}",
        "transitions: {done: B, failed: FAILED, other: FAILED, timeout: FAILED}",
    )
    d = Driver(_machine(tmp_path, text))
    d.run()
    assert d.ex.transitions[0] == {"t": 0.05, "from": "A", "to": "FAILED", "trigger": "timeout"}
    assert Scripted.stopped == ["scripted_count@0.05"]  # the skill was stopped cleanly


def test_retry_reenters_on_failure_then_takes_the_failure_transition(tmp_path):
    text = SEQUENCE.replace("    with: {ticks: 3}\n", "    with: {outcome: failed}\n    retry: 2\n")
    d = Driver(_machine(tmp_path, text))
    d.run()
    assert d.path == ["A", "A", "FAILED"]
    assert [t.get("retry") for t in d.ex.transitions] == [1, 2, None]
    assert d.ex.retries == {"A": 2}
    assert d.ctx.blackboard["scripted_count"] == 3


def test_retry_succeeds_on_a_later_attempt(tmp_path):
    text = SEQUENCE.replace(
        "    with: {ticks: 3}\n", "    with: {script: [failed, done]}\n    retry: 3\n"
    )
    d = Driver(_machine(tmp_path, text))
    d.run()
    assert d.path == ["A", "B", "DONE"] and d.ex.outcome == "succeeded"
    assert d.ex.retries == {"A": 1}


NESTED = """\
name: outer
initial: TASK
states:
  TASK:
    machine: inner.yaml
    retry: 1
    transitions: {ok: SECOND, bad: FAILED}
  SECOND:
    machine: inner.yaml
    transitions: {ok: DONE, bad: FAILED}
  DONE: {final: succeeded}
  FAILED: {final: failed}
"""
INNER = """\
name: inner
initial: X
states:
  X:
    skill: scripted
    with: {script: [failed, done], key: inner_count}
    transitions: {done: OK, failed: BAD, other: BAD}
  OK: {final: ok}
  BAD: {final: bad}
"""


def test_included_machine_outcomes_are_the_state_outcomes_and_it_is_reusable(tmp_path):
    (tmp_path / "inner.yaml").write_text(INNER)
    d = Driver(_machine(tmp_path, NESTED))
    d.run()
    steps = [(t["from"], t["to"], t["trigger"]) for t in d.ex.transitions]
    assert steps == [
        ("TASK.X", "TASK.BAD", "failed"),
        ("TASK.BAD", "TASK.X", "bad"),  # retry of TASK re-enters the nested machine
        ("TASK.X", "TASK.OK", "done"),
        ("TASK.OK", "SECOND.X", "ok"),
        ("SECOND.X", "SECOND.OK", "done"),
        ("SECOND.OK", "DONE", "ok"),
    ]
    assert d.ex.retries == {"TASK": 1}
    assert d.ex.outcome == "succeeded"


def _parallel(rule: str, a: str, a_ticks: int, b: str, b_ticks: int) -> str:
    outcomes = (
        "{succeeded: DONE, failed: FAILED}"
        if rule != "first"
        else "{done: DONE, failed: FAILED, other: FAILED}"
    )
    return f"""\
name: par
initial: BOTH
states:
  BOTH:
    rule: {rule}
    parallel:
      motion:
        skill: scripted
        with: {{outcome: {a}, ticks: {a_ticks}, key: motion}}
      monitor:
        initial: WATCH
        states:
          WATCH:
            skill: scripted
            with: {{outcome: {b}, ticks: {b_ticks}, key: monitor}}
            transitions: {{done: CALM, failed: ALARM, other: ALARM}}
          CALM: {{final: done}}
          ALARM: {{final: failed}}
    transitions: {outcomes}
  DONE: {{final: succeeded}}
  FAILED: {{final: failed}}
"""


@pytest.mark.parametrize(
    ("rule", "a", "a_ticks", "b", "b_ticks", "outcome", "end_tick", "stopped"),
    [
        ("all", "done", 2, "done", 5, "succeeded", 5, []),
        ("all", "failed", 2, "done", 5, "failed", 2, ["monitor@0.01"]),
        ("any", "failed", 2, "done", 5, "succeeded", 5, []),
        ("any", "done", 2, "failed", 5, "succeeded", 2, ["monitor@0.01"]),
        ("any", "failed", 2, "failed", 3, "failed", 3, []),
        ("first", "done", 4, "failed", 2, "failed", 2, ["motion@0.01"]),
    ],
)
def test_parallel_rules(tmp_path, rule, a, a_ticks, b, b_ticks, outcome, end_tick, stopped):
    d = Driver(_machine(tmp_path, _parallel(rule, a, a_ticks, b, b_ticks)))
    d.run()
    assert d.ex.outcome == outcome
    assert d.ex.transitions[-1]["from"] == "BOTH"
    assert d.ex.final_t == pytest.approx((end_tick - 1) * 0.01)
    # the losing branch was stopped when the state ended; finished ones stopped themselves
    losers = [s for s in Scripted.stopped if s.endswith(f"@{(end_tick - 1) * 0.01:.2f}")]
    assert set(stopped) <= set(losers)
    assert len(Scripted.stopped) == 2  # every branch skill stopped exactly once


def test_parallel_branch_states_are_recorded(tmp_path):
    d = Driver(_machine(tmp_path, _parallel("all", "done", 2, "done", 3)))
    d.run()
    steps = [(t["from"], t["to"]) for t in d.ex.transitions]
    assert ("BOTH", "BOTH.monitor.WATCH") in steps
    assert ("BOTH.monitor.WATCH", "BOTH.monitor.CALM") in steps


GUARDED = """\
name: guarded
initial: A
guards: [flag]
on_abort: HOLD
states:
  A:
    skill: scripted
    with: {ticks: 5}
    guards: [{flag: {flag: local_danger}}]
    transitions: {done: B, failed: FAILED, other: FAILED}
  B:
    skill: scripted
    with: {ticks: 5, key: b}
    transitions: {done: DONE, failed: FAILED, other: FAILED}
  HOLD:
    skill: scripted
    with: {ticks: 2, key: hold}
    transitions: {done: STOPPED, failed: STOPPED, other: STOPPED}
  DONE: {final: succeeded}
  FAILED: {final: failed}
  STOPPED: {final: failed}
"""


def test_state_guards_are_active_only_in_their_state(tmp_path):
    d = Driver(_machine(tmp_path, GUARDED))
    names_in_a = sorted(g.params.flag for g in d.ex.active_guards)
    assert names_in_a == ["danger", "local_danger"]
    d.tick(5)
    assert d.ex.leaf == "B"
    assert [g.params.flag for g in d.ex.active_guards] == ["danger"]


def test_abort_goes_to_on_abort_from_any_state_and_ends_aborted(tmp_path):
    d = Driver(_machine(tmp_path, GUARDED))
    d.tick(6)
    assert d.ex.leaf == "B"
    violation = d.ex.active_guards[0].check(d.ctx)
    assert violation is None
    d.ctx.blackboard["danger"] = True
    d.ex.abort(d.ex.active_guards[0].check(d.ctx))
    assert d.ex.leaf == "SAFE_STOP"  # the controlled stop runs first
    assert d.ex.active_guards == []  # the safety response runs unguarded
    assert Scripted.stopped[-1].startswith("b@")  # B was stopped
    d.tick(1)
    assert d.ex.leaf == "HOLD"  # the arm is at rest: on_abort runs
    d.run()
    assert d.ex.outcome == "aborted" and d.ex.final_state == "STOPPED"
    assert d.ex.transitions[1] == {"t": 0.06, "from": "B", "to": "SAFE_STOP", "trigger": "abort"}
    assert d.ex.transitions[2]["from"] == "SAFE_STOP" and d.ex.transitions[2]["to"] == "HOLD"
    assert d.ex.transitions[2]["trigger"] == "stopped"
    assert any(e.level == "ERROR" and e.kind == "violation" for e in d.ctx.events)


def test_abort_without_on_abort_holds_the_pose_in_the_safe_stop(tmp_path):
    d = Driver(_machine(tmp_path, SEQUENCE.replace("with: {ticks: 3}", "with: {ticks: 30}")))
    d.tick(2)
    from orchestrator.guards.base import Violation

    d.ex.abort(Violation("flag", "test", 1, 0))
    assert d.ex.transitions[-1]["to"] == "SAFE_STOP"
    assert d.ex.stop is not None and d.ex.stop.reasons == ["flag: test"]  # the stop started
    d.run()
    assert d.ex.outcome == "aborted" and d.ex.final_state == "SAFE_STOP"
    assert d.ex.final_t == pytest.approx(0.02 + 0.05)
