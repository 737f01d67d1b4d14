"""The three lifetimes (docs/architecture.md, "Lifetimes"): the cell lives as long as the world,
the `Context` as long as an episode, and a live task gets a fresh one.

A skill written against docs/skill-api.md, as a user writes one in a folder of their own (the
probe below uses the page's skill-facing members as the page documents them), runs unchanged
in `orchestrator run` and in a live session.
"""

from __future__ import annotations

import gc
import textwrap
from pathlib import Path

import pytest
from orchestrator.skills.registry import register_skill_path

from orchestrator.engine.cell import Cell
from orchestrator.engine.context import Context
from orchestrator.engine.runner import run_episode
from orchestrator.language.load import load_scenario
from orchestrator.live.protocol import Command
from orchestrator.live.session import Session

PROBE = '''
"""A user's skill, written against docs/skill-api.md: it touches the documented members."""

from typing import ClassVar

import numpy as np
from pydantic import Field

from orchestrator.skills import Skill, SkillParams


class ProbeParams(SkillParams):
    duration_s: float = Field(default=0.1, ge=0.0, description="How long it watches [s].")


class DocsProbe(Skill):
    """Reads the robot and the world the documented way, logs, writes the blackboard."""

    name: ClassVar[str] = "docs_probe"
    Params: ClassVar[type[SkillParams]] = ProbeParams
    outcomes: ClassVar[tuple[str, ...]] = ("done", "broken")

    def start(self, ctx):
        self.t0 = ctx.clock
        ctx.controller.hold(ctx.q)
        ctx.ik.reset(ctx.q)
        ctx.set_gripper(ctx.robot.gripper_open_m)
        ctx.log("probe", "watching", level="INFO", tick=ctx.tick)
        seen = ctx.blackboard["seen"] if "seen" in ctx.blackboard else 0
        ctx.blackboard["seen"] = seen + 1
        self.grasped_before = dict(ctx.grasped_at)
        ctx.grasped_at["cube"] = float(ctx.object_pose("cube").pos[2])

    def step(self, ctx):
        n = ctx.robot.n_arm
        q, qd = ctx.robot_q()
        f = ctx.wrist_force()
        norm_sq = ctx.wrist_force_norm_sq()
        ok = (
            ctx.q.shape == (n,) and ctx.qd.shape == (n,) and len(q) >= n and len(qd) >= n
            and ctx.tcp_pos.shape == (3,) and ctx.tcp_rot.shape == (3, 3)
            and f.shape == (3,) and abs(float(f @ f) - norm_sq) <= 1e-9 * max(1.0, norm_sq)
            and ctx.wrist_force_age_s() == 0.0
            and ctx.joint_torque.shape == (n,)
            and 0.0 <= ctx.gripper_width and ctx.gripper_target == ctx.robot.gripper_open_m
            and isinstance(ctx.gripper_commanded, bool)
            and ctx.object_handle("cube") is ctx.world.objects["cube"]
            and ctx.perceived(ctx.object_pose("cube")) is not None
            and ctx.start_pose("cube").pos[2] > 0.0
            and ctx.model is ctx.world.model and ctx.data is ctx.world.data
            and ctx.scenario.name == "docs_cell" and ctx.workspace_box is None
            and 0.0 <= ctx.rng.random() < 1.0
            and ctx.dt_physics < ctx.dt_control and ctx.t >= ctx.clock
            and ctx.clock_rate == 1.0 and ctx.tick >= 0 and len(ctx.events) >= 1
        )
        if not ok:
            return "broken"
        if ctx.clock - self.t0 >= self.params.duration_s:
            ctx.metrics["probe_events"] = len(ctx.events)
            ctx.metrics["probe_grasped_before"] = len(self.grasped_before)
            ctx.metrics["probe_seen"] = ctx.blackboard["seen"]
            return "done"
        return None
'''

MACHINE = """\
name: docs_probe_machine
initial: PROBE
blackboard:
  wait_s: {type: float, default: 0.1, input: true, description: "How long the probe watches [s]."}
states:
  PROBE:
    skill: docs_probe
    with: {duration_s: $wait_s}
    transitions: {done: DONE, broken: FAILED}
  DONE: {final: succeeded}
  FAILED: {final: failed}
"""


@pytest.fixture(scope="module")
def cell_files(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A scenario of one's own whose machine runs the user's probe skill."""
    folder = tmp_path_factory.mktemp("docs_cell")
    (folder / "probe.py").write_text(textwrap.dedent(PROBE))
    register_skill_path(folder / "probe.py")
    (folder / "m.yaml").write_text(MACHINE)
    scenario = folder / "s.yaml"
    scenario.write_text(
        "name: docs_cell\nmachine: m.yaml\n"
        "scene:\n  objects:\n    - {name: cube, size: [0.05, 0.05, 0.05], xy: [0.5, 0.0]}\n"
    )
    return scenario


def test_a_skill_written_against_the_documented_api_runs_unchanged(cell_files):
    result = run_episode(load_scenario(str(cell_files)), 0)
    assert result.outcome == "succeeded", (result.final_state, result.metrics)
    assert result.metrics["probe_seen"] == 1
    assert result.metrics["probe_grasped_before"] == 0
    assert result.metrics["probe_events"] >= 1


def _task_done(session: Session, limit: int = 2_000) -> Context | None:
    """Run `session`'s loop (its steps, without the wall-clock pacing) until no task runs or
    waits; returns the context of the last task that ran."""
    ctx = None
    for _ in range(limit):
        session._drain()
        if session.task is None and session.tasks and not (session.estopped or session.error):
            session._start_next()
        if session.task is not None:
            ctx = session.task.ctx
        session._tick()
        session._after_tick()
        if session.task is None and not session.tasks:
            return ctx
    raise AssertionError(f"the task did not end in {limit} control ticks")


def _run(session: Session) -> dict:
    reply = session.submit(Command(op="run", machine="m.yaml", client="test"))
    assert reply.accepted, reply.reason
    _task_done(session)
    assert session.last_result is not None
    return session.last_result


def test_each_live_task_gets_a_fresh_context_on_the_same_cell(cell_files):
    session = Session(str(cell_files), "lifetimes", speed=0.0)
    idle = session.ctx
    first = _run(session)
    assert first["outcome"] == "succeeded", first
    cell, tick = session.cell, session.cell.tick
    second = _run(session)
    assert second["outcome"] == "succeeded", second
    # the episode's state starts empty: the blackboard, the grasp heights, the events
    assert second["metrics"]["probe_seen"] == 1
    assert second["metrics"]["probe_grasped_before"] == 0
    assert second["metrics"]["probe_events"] == first["metrics"]["probe_events"]
    # the world's goes on: the same cell, its tick count and clock running on
    assert session.cell is cell and session.cell.tick > tick
    assert second["metrics"]["t_start"] > first["metrics"]["t_start"]
    # between tasks the loop steps for the session's idle context, which tasks leave alone
    assert session.loop.ctx is session.ctx is idle
    assert not idle.events and not idle.grasped_at and not idle.metrics


def _rss_kib() -> int:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1])
    pytest.skip("no /proc/self/status on this system")


def _context_size(ctx: Context) -> int:
    """What an episode accumulates: events, listeners, grasp heights, metrics, camera shots,
    blackboard values, task log entries."""
    return (
        len(ctx.events) + len(ctx.listeners) + len(ctx.grasped_at) + len(ctx.metrics)
        + len(ctx.camera_shots) + len(ctx.blackboard.as_dict()) + len(ctx.tasks.entries)
    )  # fmt: skip


@pytest.mark.slow
def test_a_session_of_1000_tasks_keeps_the_context_and_the_rss_flat(cell_files):
    """1,000 short tasks: every task's context holds only its own episode (its size the
    same for the last task as for the first), at most the idle and the current context are
    alive, and the process's resident memory grows by less than 16 MiB from task 100 to
    task 1,000 (measured on the branch: see docs/architecture.md, "Lifetimes")."""
    session = Session(str(cell_files), "thousand", speed=0.0)
    sizes, rss = [], {}
    for n in range(1, 1001):
        result = session.submit(
            Command(op="run", machine="m.yaml", client="test", set=["wait_s=0.0"])
        )
        assert result.accepted, result.reason
        ctx = _task_done(session)
        assert session.last_result is not None and session.last_result["outcome"] == "succeeded"
        assert ctx is not None
        sizes.append(_context_size(ctx))
        del ctx
        if n in (100, 1000):
            gc.collect()
            rss[n] = _rss_kib()
            alive = [o for o in gc.get_objects() if isinstance(o, Context)]
            assert len(alive) <= 3, f"{len(alive)} contexts alive after {n} tasks"
    assert max(sizes) == sizes[0], (sizes[0], max(sizes))
    assert session.cell.tick > 1000
    grown_mib = (rss[1000] - rss[100]) / 1024
    print(f"context size {sizes[0]}..{max(sizes)}; RSS {rss[100] / 1024:.1f} MiB at task 100, "
          f"{rss[1000] / 1024:.1f} MiB at task 1000 ({grown_mib:+.1f} MiB)")  # fmt: skip
    assert grown_mib < 16.0, f"RSS grew {grown_mib:.1f} MiB from task 100 to task 1000"
    assert isinstance(session.cell, Cell)
