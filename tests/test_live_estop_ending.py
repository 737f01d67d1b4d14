"""An e-stop that lands while a task brings the arm to rest at its end (its machine has
ended; a gentle, category-2 stop, the motors holding, then the scene settling) takes the arm
as it does from a running machine: the e-stop's own stop, then the holding brakes.

Found by the live protocol's model test (tests/test_live_model.py, long profile): a `recover`
ended at once (`clear`) and, during its end, two e-stops landed; the task's gentle stop kept
the arm on its motors, which let it creep at 0.017 rad/s while ESTOPPED, until the stop gave
up 2 s later. Before the fix the e-stop went to the idle world's stop, which is only stepped
once no task is left."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from orchestrator.live.protocol import Command
from orchestrator.live.session import Session

SWING = """name: swing
initial: SWING
states:
  SWING:
    skill: move_joints
    with: {to: [1.2, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785], max_speed: 1.0}
    timeout: 0.3
    transitions: {reached: DONE, timeout: DONE}
  DONE: {final: succeeded}
"""
"""Ends mid-swing (the state's timeout, joint 1 near 0.8 rad/s): the task's end brings the
arm to rest."""


def _tick(session: Session) -> None:
    """One pass of the session's loop, without the transport and the pacing."""
    session._drain()
    if session.task is None and session.tasks and not (session.estopped or session.error):
        session._start_next()
    session._tick()
    session._after_tick()


def test_an_estop_during_a_tasks_end_brakes_the_arm(tmp_path: Path):
    events: list[dict] = []
    (tmp_path / "swing.yaml").write_text(SWING)

    def publish(leaf: str, msg: dict) -> None:
        if leaf == "events":
            events.append(msg)

    session = Session("pick_place", "ending", seed=3, speed=0.0, allow_paths=[tmp_path],
                      publish=publish)  # fmt: skip
    assert session.submit(Command(op="run", machine=str(tmp_path / "swing.yaml"))).accepted
    for _ in range(200):
        _tick(session)
        task = session.task
        if task is not None and task.executor is not None and task.executor.done:
            break
    else:
        raise AssertionError("the swing never ended")
    world = session.world
    assert float(np.max(np.abs(world.data.qvel[world.arm_dof]))) > 0.3  # still swinging
    assert not world.braked

    session.estop("test")
    t_stop = session.ctx.t
    held_by_motors = []
    for _ in range(60):  # 0.6 s of simulated time
        _tick(session)
        if session.task is not None and session.ctx.t - t_stop >= 0.1:
            held_by_motors.append(round(session.ctx.t - t_stop, 3))
        if session.task is None:
            assert len(world.braked) == session.ctx.robot.n_arm  # every joint braked
    assert session.task is None and session.state == "ESTOPPED"
    assert not held_by_motors, (
        f"the task kept the arm on its motors {held_by_motors} s after the e-stop"
    )
    assert session.last_estop is not None and session.last_estop["ticks"] <= 1
    ends = [e for e in events if e["event"] == "task_end"]
    assert len(ends) == 1 and ends[0]["result"]["machine"] == str(tmp_path / "swing.yaml")
