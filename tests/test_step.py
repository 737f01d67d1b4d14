"""One step function: `orchestrator run` and a live session step the world through the same code.

A per-step feature added to `StepLoop` reaches both; these tests hold the live session to
what a run has (per-step observers, the peak wrist force, the guards of the safety response)
and the shared end of an episode (the time limit counts the skills' clock, not paused time).
"""

from __future__ import annotations

from orchestrator.engine.episode import make_executor
from orchestrator.engine.runner import run_episode
from orchestrator.language.load import load_scenario
from orchestrator.live.protocol import Command
from orchestrator.live.session import Session


class _StepCounter:
    """An observer counting physics steps and control ticks."""

    def __init__(self) -> None:
        self.steps = 0
        self.ticks = 0

    def on_start(self, ctx, executor) -> None:
        pass

    def on_tick(self, ctx, executor) -> None:
        self.ticks += 1

    def on_step(self, ctx) -> None:
        self.steps += 1

    def on_end(self, ctx, executor, result) -> None:
        pass


def _run_task(session: Session, machine: str, sets: list[str]) -> dict:
    reply = session.submit(Command(op="run", machine=machine, set=sets))
    assert reply.accepted, reply.reason
    session._drain()
    session._start(session.tasks.popleft())
    for _ in range(3000):
        session._tick()
        if session.task is None:
            break
    assert session.last_result is not None, "the task did not end in 30 s"
    return session.last_result


def test_a_run_calls_per_step_observers_on_every_physics_step():
    counter = _StepCounter()
    result = run_episode(load_scenario("pick_place"), 0, [counter])
    ticks = result.metrics["control_ticks"]
    assert counter.steps == ticks * 5  # 100 Hz control, 500 Hz physics
    assert counter.ticks >= ticks


def test_a_live_task_is_stepped_like_a_run_observers_peak_force_and_ticks():
    counter = _StepCounter()
    session = Session("pick_place", "s", seed=3, speed=0.0, recorder=lambda task: counter)
    result = _run_task(session, "reach", ["target=[0.5, 0.1, 0.4]"])
    assert result["outcome"] == "succeeded", result
    ticks = result["metrics"]["control_ticks"]
    # the live loop used to step the physics without telling a recorder about it
    assert ticks > 0 and counter.steps == ticks * session.cell.n_sub
    assert "max_wrist_force_n" in result["metrics"]
    assert result["metrics"]["t_start"] >= 0.0


def test_a_live_task_has_the_guards_that_watch_the_safety_response():
    # a run's executor keeps the joint limits and a force ceiling on during the controlled
    # stop of an abort; a live task's had none
    session = Session("pick_place", "s", seed=3, speed=0.0)
    reply = session.submit(Command(op="run", machine="home"))
    assert reply.accepted
    session._drain()
    task = session.tasks.popleft()
    task.start()
    assert task.executor is not None
    assert [g.name for g in task.executor.response_guards] == ["joint_limits"]
    assert [g.name for g in task.executor.stopped_guards] == ["contact_force"]
    run_ex = make_executor(load_scenario("pick_place"), session.ctx)
    assert [g.name for g in run_ex.response_guards] == ["joint_limits"]


def test_the_time_limit_counts_the_skills_clock_not_paused_time():
    # 2 s paused inside a 3 s limit: the run goes on past t = 3 s of simulated time
    sets = ["physics.time_limit_s=2.5"]
    paused = load_scenario("pick_place", sets, events=["0.5:pause", "2.5:resume"])
    result = run_episode(paused, 0)
    assert result.metrics["paused_s"] >= 1.9
    assert result.sim_time > 2.5 + 1.9 - 0.05
    assert result.metrics.get("time_limit_reached") is True  # the pick takes ~3 s


def test_a_step_loop_reports_divergence_with_the_state():
    scenario = load_scenario("pick_place")
    from orchestrator.engine.cell import Cell
    from orchestrator.engine.context import Context
    from orchestrator.engine.runner import initial_blackboard

    cell = Cell.build(scenario.scenario, 0)
    world = cell.world
    ctx = Context(cell, initial_blackboard(scenario.machine, {}))
    loop = cell.loop
    loop.bind(ctx)
    assert loop.tick(None) is None
    world.data.qvel[0] = float("nan")
    message = loop.tick(None)
    assert message is not None and message.startswith("physics diverged at t=")
