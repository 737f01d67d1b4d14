"""Events: the `events:` language, `--event`, e-stop, pause/resume and machine events."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from orchestrator.engine.executor import Executor
from orchestrator.engine.runner import initial_blackboard, run_episode
from orchestrator.exceptions import ConfigError
from orchestrator.language.diagnostics import Diagnostic
from orchestrator.language.events import parse_event_spec
from orchestrator.language.load import load_machine, load_scenario

from .scripted import FakeContext, InstantStop, Scripted, register

# -- the syntax ---------------------------------------------------------------------------------


def test_an_event_spec_is_a_time_and_a_name():
    assert parse_event_spec("1.5:estop") == {"at": 1.5, "event": "estop"}
    assert parse_event_spec(" 2 : go_home ") == {"at": 2.0, "event": "go_home"}


@pytest.mark.parametrize(
    ("text", "words"),
    [("estop", "expected T:NAME"), ("x:pause", "not a number"), ("-1:pause", "non-negative"),
     ("nan:pause", "finite"), ("1.0:", "expected T:NAME")],
)  # fmt: skip
def test_a_broken_event_spec_is_a_diagnostic(text, words):
    diag = parse_event_spec(text)
    assert isinstance(diag, Diagnostic) and diag.file == "<--event>" and words in diag.message


def test_an_unknown_event_exits_2_listing_the_valid_ones(cli):
    res = cli("run", "pick_place", "--event", "1.0:bogus")
    assert res.exit_code == 2, res.stdout
    assert "no event 'bogus'" in res.stderr and "estop, pause, resume" in res.stderr
    assert "Traceback" not in res.stderr


def _machine_text(events: str, timeout: float | None = None) -> str:
    limit = "" if timeout is None else f"    timeout: {timeout}\n"
    return (
        "name: m\ninitial: A\n" + events + "states:\n"
        "  A:\n    skill: scripted\n    with: {ticks: 1000}\n"
        + limit
        + "    transitions: {done: DONE, failed: FAILED, other: FAILED"
        + ("}\n" if timeout is None else ", timeout: DONE}\n")
        + "  HOME:\n    skill: scripted\n    with: {ticks: 2}\n"
        "    transitions: {done: STOPPED, failed: FAILED, other: FAILED}\n"
        "  DONE: {final: succeeded}\n  STOPPED: {final: failed}\n  FAILED: {final: failed}\n"
    )


@pytest.fixture
def scripted(monkeypatch):
    from orchestrator.skills import SKILLS

    from orchestrator.guards import GUARDS

    register()
    Scripted.stopped.clear()
    yield
    SKILLS.pop("scripted", None)
    GUARDS.pop("flag", None)


@pytest.mark.parametrize(
    ("events", "words"),
    [
        ("events: {stop: NOWHERE}\n", "unknown state 'NOWHERE'"),
        ("events: {estop: HOME}\n", "'estop' is a built-in event and cannot be mapped"),
        ("events: {pause: HOME}\n", "built-in event"),
        ("events: {Stop-Now: HOME}\n", "lowercase identifier"),
    ],
)
def test_machine_events_are_checked_like_transitions(tmp_path, scripted, events, words):
    path = tmp_path / "m.yaml"
    path.write_text(_machine_text(events))
    with pytest.raises(ConfigError) as info:
        load_machine(str(path))
    assert words in str(info.value) and f"{path}:3:" in str(info.value)


def test_a_state_reached_only_through_an_event_is_not_unreachable(tmp_path, scripted):
    path = tmp_path / "m.yaml"
    path.write_text(_machine_text("events: {stop: HOME}\n"))
    assert load_machine(str(path)).events == {"stop": "HOME"}


# -- the executor (scripted skills, no physics) ---------------------------------------------------


def _driver(
    tmp_path: Path, events: str, timeout: float | None = None
) -> tuple[Executor, FakeContext]:
    path = tmp_path / "m.yaml"
    path.write_text(_machine_text(events, timeout))
    node = load_machine(str(path))
    ctx = FakeContext()
    ctx.blackboard = initial_blackboard(node, {})
    ex = Executor(node, ctx, [], InstantStop, hold_s=0.05)  # type: ignore[arg-type]
    ex.start()
    return ex, ctx


def _tick(ex: Executor, ctx: FakeContext, n: int) -> None:
    for _ in range(n):
        ex.tick()
        ctx.t = round(ctx.t + ctx.dt_control, 9)


def test_a_machine_event_preempts_the_active_state(tmp_path, scripted):
    ex, ctx = _driver(tmp_path, "events: {stop: HOME}\n")
    _tick(ex, ctx, 5)
    assert ex.event("stop", "test") is True
    assert ex.leaf == "A"  # takes effect at the next control tick
    _tick(ex, ctx, 1)
    assert ex.leaf == "HOME" and Scripted.stopped == ["scripted_count@0.05"]
    assert ex.transitions[-1] == {"t": 0.05, "from": "A", "to": "HOME", "trigger": "stop"}
    _tick(ex, ctx, 5)
    assert ex.done and ex.final_state == "STOPPED"


def test_an_unknown_event_changes_nothing(tmp_path, scripted):
    ex, ctx = _driver(tmp_path, "events: {go_home: HOME}\n")
    assert ex.event("stop", "test") is False
    _tick(ex, ctx, 3)
    assert ex.leaf == "A" and not ex.events


def test_a_pause_stops_the_clock_of_timeouts_and_a_resume_continues_it(tmp_path, scripted):
    ex, ctx = _driver(tmp_path, "events: {stop: HOME}\n", timeout=0.5)
    _tick(ex, ctx, 10)
    ex.event("pause", "test")
    _tick(ex, ctx, 200)  # 2 s paused: the 0.5 s timeout would long have fired
    assert ex.leaf == "A" and not ex.done and ex.pause.held
    ex.event("resume", "test")
    _tick(ex, ctx, 100)
    assert ex.done and ex.transitions[-1]["trigger"] == "timeout"
    assert ex.pause.pauses[0]["t"] == 0.1 and ex.pause.pauses[0]["resume_t"] == 2.1
    # a pause of 2.0 s delays the timeout by 2.0 s: the ramps are symmetric
    assert ex.transitions[-1]["t"] == pytest.approx(0.5 + 2.0, abs=0.011)


def test_a_second_pause_is_ignored_and_says_why(tmp_path, scripted):
    ex, ctx = _driver(tmp_path, "events: {stop: HOME}\n")
    ex.event("pause", "a")
    ex.event("pause", "b")
    ex.event("resume", "c")
    ex.event("resume", "d")
    _tick(ex, ctx, 1)
    assert [e.get("ignored") for e in ex.events] == [None, "already paused", None, "not paused"]


# -- physics ----------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def uninterrupted():
    return run_episode(load_scenario("pick_place"), 3)


def test_an_estop_event_is_the_estop_fault(cli):
    ev = cli("run", "pick_place", "--seed", "3", "--event", "1.5:estop", "--json")
    fault = cli("run", "pick_place", "--seed", "3", "--fault", "estop@1.5", "--json")
    assert ev.exit_code == 3 and fault.exit_code == 3
    a, b = json.loads(ev.stdout), json.loads(fault.stdout)
    assert a["reason"]["guard"] == "estop" and a["outcome"] == "aborted"
    assert a["metrics"]["stop_time_s"] <= 0.15
    # one mechanism: the same stop, the same pose, the same end
    for key in ("sim_time", "final_state", "transitions"):
        assert a[key] == b[key]
    assert a["metrics"]["stop_distance_mm"] == b["metrics"]["stop_distance_mm"]


def test_a_pause_holds_the_arm_and_delays_the_run_by_its_length(uninterrupted):
    # the command: paused at 1.0 s (approaching the cube), resumed at 2.0 s
    result = run_episode(load_scenario("pick_place", events=["1.0:pause", "2.0:resume"]), 3)
    assert result.outcome == "succeeded"
    # (to 0.1 s: the pause catches the hand closing, whose drive then meets the cube at a
    # different speed and detects the block a few ticks apart; 0.06 s on this seed)
    assert result.sim_time == pytest.approx(uninterrupted.sim_time + 1.0, abs=0.1)
    (pause,) = result.metrics["pauses"]
    assert pause["held_t"] is not None and pause["drift_mm"] <= 1.0
    # the pause lasts what was asked, to one control tick (events act at tick boundaries)
    assert result.metrics["paused_s"] == pytest.approx(1.0, abs=0.0101)


def test_events_are_deterministic():
    events = ["1.0:pause", "2.0:resume"]
    a = run_episode(load_scenario("pick_place", events=events), 3)
    b = run_episode(load_scenario("pick_place", events=events), 3)
    assert a.model_dump(exclude={"wall_time"}) == b.model_dump(exclude={"wall_time"})
    assert np.isfinite(a.sim_time)


def test_a_scenario_lists_events_with_their_location(write_yaml):
    path = write_yaml(
        "s.yaml",
        "name: s\nmachine: pick_place\nscene:\n  objects:\n"
        "    - {name: cube, size: [0.05, 0.05, 0.05], xy: [0.5, -0.12]}\n"
        "  markers: [{name: pad, xy: [0.5, 0.2]}]\n"
        "events:\n  - {at: 1.0, event: go_home}\n",
    )
    with pytest.raises(ConfigError) as info:
        load_scenario(str(path))
    assert f"{path}:8:" in str(info.value) and "no event 'go_home'" in str(info.value)
