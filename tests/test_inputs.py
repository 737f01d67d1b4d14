"""Safety parameters are not commands: a live command or a planner's reply sets only a
machine's inputs, and every value that becomes a position is checked before anything moves."""

from __future__ import annotations

import numpy as np
import pytest

from orchestrator.language.inputs import machine_inputs
from orchestrator.language.load import load_machine
from orchestrator.live.protocol import Command
from orchestrator.live.session import Session


@pytest.fixture(scope="module")
def session() -> Session:
    return Session("pick_place", "inputs", seed=3, speed=0.0)


def _run(session: Session, machine: str, *sets: str):
    return session.submit(Command(op="run", machine=machine, set=list(sets)))


class _Joints:
    """Every physics step's arm joint angles (ground truth, not the log)."""

    def __init__(self, session: Session) -> None:
        self.idx = session.world.arm_qpos
        self.q: list[np.ndarray] = []
        session.loop.set_observers([self])

    def on_step(self, ctx) -> None:
        self.q.append(ctx.data.qpos[self.idx].copy())


@pytest.mark.parametrize(
    ("machine", "inputs"),
    [
        ("reach", {"target": "vec3"}),
        ("pick_place", {"object": "str", "pick_at": "vec3", "place_at": "any"}),
        ("home", {}),
        ("grasp", {"object_pose": "pose"}),  # read by its motions, written by no skill of it
        ("sorting", {"look_from": "vec3"}),  # `place_at` there is written by `lookup`
    ],
)
def test_a_machines_inputs_are_its_goal_like_keys_unless_declared(machine, inputs):
    assert machine_inputs(load_machine(machine)) == inputs


def test_input_flags_override_the_default(tmp_path):
    path = tmp_path / "m.yaml"
    path.write_text(
        "name: m\ninitial: GO\nblackboard:\n"
        "  goal: {type: vec3, default: [0.5, 0, 0.4], input: false}\n"
        "  lift: {type: vec3, default: [0, 0, 0.1], input: true}\n"
        "  speed: {type: float, default: 0.2}\n"
        "states:\n  GO:\n    skill: move\n"
        "    with: {target: $goal, offset: $lift, max_speed: $speed}\n"
        "    transitions: {reached: DONE, unreachable: DONE, timeout: DONE}\n"
        "  DONE: {final: succeeded}\n"
    )
    assert machine_inputs(load_machine(str(path))) == {"lift": "vec3"}


def test_an_input_a_skill_overwrites_is_a_located_error(cli, tmp_path):
    path = tmp_path / "m.yaml"
    path.write_text(
        "name: m\ninitial: FIND\nblackboard:\n"
        "  object_pose: {type: pose, input: true}\n"
        "states:\n  FIND:\n    skill: search\n    with: {object: cube}\n"
        "    transitions: {found: DONE, not_found: DONE}\n  DONE: {final: succeeded}\n"
    )
    res = cli("validate", str(path))
    assert res.exit_code == 2
    assert (
        f"{path}:4:29: blackboard.object_pose.input: 'object_pose' is written by the skill of "
        "FIND: a value sent would be overwritten before it is read" in res.stderr
    ), res.stderr


def test_recovery_below_the_top_is_a_located_error(cli, tmp_path):
    (tmp_path / "inner.yaml").write_text(
        "name: inner\ninitial: A\nrecovery: true\nstates:\n  A: {final: done}\n"
    )
    outer = tmp_path / "outer.yaml"
    outer.write_text(
        "name: outer\ninitial: IN\nstates:\n  IN:\n    machine: inner.yaml\n"
        "    transitions: {done: DONE}\n  DONE: {final: succeeded}\n"
    )
    res = cli("validate", str(outer))
    assert res.exit_code == 2 and "recovery: `recovery` takes effect only in the top" in res.stderr
    assert cli("validate", str(tmp_path / "inner.yaml")).exit_code == 0


SCENARIO_VALUES = [
    "guards={}",
    "guards.workspace.max=[0.95, 0.7, 1.2]",
    "physics.safe_stop.max_decel_rad_s2=1",
    "scene.table.height=0.1",
    "robot.base_pos=[0, 0, 0.1]",
    "machine=reach",
    "parcels=3",
    "skills=[/tmp]",
    "blackboard.target=[0.5, 0.1, 0.4]",
]


@pytest.mark.parametrize("value", SCENARIO_VALUES)
def test_a_scenario_value_over_the_channel_is_refused_and_nothing_moves(session, value):
    reply = _run(session, "reach", "target=[0.5, 0.1, 0.4]", value)
    key = value.partition("=")[0]
    assert not reply.accepted
    assert reply.reason == (
        f"`{key}` is a scenario value, not an input: a live command or a planner may set only "
        "the machine's inputs; limits and scenario values change only by starting a session "
        "with another scenario"
    )
    assert session.inbox.empty() and not session.tasks


def test_refused_commands_leave_every_physics_step_as_if_none_had_come():
    """Two sessions stepped alike, one sent every refused command: the arm's joint angles of
    every physics step are the same, bit for bit (0.0 mm of motion from the commands)."""
    quiet = Session("pick_place", "quiet", seed=3, speed=0.0)
    attacked = Session("pick_place", "attacked", seed=3, speed=0.0)
    probes = [_Joints(quiet), _Joints(attacked)]
    for i in range(60):
        if i % 6 == 0:
            for value in SCENARIO_VALUES:
                assert not _run(attacked, "reach", "target=[0.5, 0.1, 0.4]", value).accepted
            assert not _run(attacked, "pick_place", "hover=[0, 0, 5]").accepted
        for s in (quiet, attacked):
            s._drain()
            s._tick()
    a, b = (np.array(p.q) for p in probes)
    assert len(a) == 60 * quiet.cell.n_sub and np.array_equal(a, b)


def test_a_key_that_is_not_an_input_is_refused(session):
    reply = _run(session, "pick_place", "hover=[0, 0, 5]")
    assert not reply.accepted and reply.reason == (
        "`hover` is not an input of machine 'pick_place': a key is one when the machine "
        "declares it `input: true`, or by default when a motion target or a position hint "
        "reads it (valid: object, pick_at, place_at)"
    )
    refused = _run(session, "pick_place", "object_pose={pos: [0.5, 0, 0.3], quat: [1, 0, 0, 0]}")
    assert not refused.accepted and "`object_pose` is not an input" in refused.reason


@pytest.mark.parametrize(
    ("value", "shown"),
    [
        ("target=[.nan, 0.0, 0.4]", "target = [nan, 0.0, 0.4]: not finite"),
        ("target=[.inf, 0.0, 0.4]", "target = [inf, 0.0, 0.4]: not finite"),
        ("target=NaN", "target = 'NaN': not finite"),
    ],
)
def test_a_nan_target_is_refused_as_not_finite(session, value, shown):
    reply = _run(session, "reach", value)
    assert not reply.accepted and reply.reason == shown


def test_an_offset_is_checked_as_a_goal_over_the_channel(session, tmp_path):
    """A machine may make an offset an input: the positions it makes are then goals."""
    (tmp_path / "hover.yaml").write_text(
        "name: hover\ninitial: UP\nblackboard:\n"
        "  hover: {type: vec3, default: [0, 0, 0.1], input: true}\n"
        "states:\n  UP:\n    skill: move\n    with: {target: pad, offset: $hover}\n"
        "    transitions: {reached: DONE, unreachable: DONE, timeout: DONE}\n"
        "  DONE: {final: succeeded}\n"
    )
    session.allow_paths = (tmp_path,)
    try:
        reply = _run(session, str(tmp_path / "hover.yaml"), "hover=[0, 0, 5]")
        assert not reply.accepted and reply.reason == (
            "goal rejected: hover = [0.0, 0.0, 5.0]: UP: pad at [0.5, 0.2, 0.2] + $hover = "
            "[0.5, 0.2, 5.2]: outside the workspace [[0.05, -0.6, 0.15] .. [0.95, 0.6, 1.2]] m"
        )
        ok = _run(session, str(tmp_path / "hover.yaml"), "hover=[0, 0, 0.15]")
        assert ok.accepted, ok.reason
    finally:
        session.allow_paths = ()
        session.tasks.clear()
        session._pending.clear()  # accepted, not yet drained: the queue policy counts them
        while not session.inbox.empty():
            session.inbox.get_nowait()


def test_a_place_is_checked_with_the_offsets_the_machine_adds(session):
    """Every position is tested against the workspace box first, the IK only then."""
    reply = _run(session, "pick_place", "place_at=[0.5, 0.2, 1.15]")
    assert not reply.accepted
    assert reply.reason.startswith(
        "goal rejected: place_at = [0.5, 0.2, 1.15]: TRANSPORT.via[0]: $place_at + $place_hover "
        "= [0.5, 0.2, 1.22]: outside the workspace"
    ), reply.reason


def test_run_checks_an_offset_set_on_the_command_line_against_the_objects(cli):
    """`orchestrator run --set` may change anything, but a 5 m hover is still refused: the
    pose a search will write is taken where the object is now."""
    res = cli("run", "pick_place", "--set", "hover=[0, 0, 5]")
    assert res.exit_code == 2 and "Traceback" not in res.stderr
    assert (
        "<--set>: goal rejected: hover = [0.0, 0.0, 5.0]: PICK.GRASP.APPROACH.motion.via[0]: "
        "$grasp_pose (cube at [0.4366, -0.1868, 0.225]) + $hover = [0.4366, -0.1868, 5.225]: "
        "outside the workspace" in res.stderr
    ), res.stderr


def test_a_position_hint_far_from_every_object_is_refused(session):
    cube = session.ctx.object_pose("cube").pos
    far = [round(cube[0] + 0.1, 4), round(cube[1], 4), 0.2]
    reply = _run(session, "pick_place", f"pick_at={far}")
    assert not reply.accepted
    assert reply.reason == (
        f"goal rejected: pick_at = {far}: the position hint of PICK.SEARCH.near: nothing "
        f"within 50 mm of it (the nearest, cube at {np.round(cube, 4).tolist()}, is 100 mm "
        "away in the horizontal plane)"
    )
