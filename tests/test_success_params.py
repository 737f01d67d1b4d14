"""A success check's parameters from the blackboard (`$key`, read as the run ends and validated
then) and where each object started (`ctx.start_pose`)."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from orchestrator.robots import Controller

from orchestrator.engine.blackboard import Blackboard
from orchestrator.engine.cell import Cell
from orchestrator.engine.context import Context
from orchestrator.engine.success import errors, evaluate
from orchestrator.exceptions import SkillError
from orchestrator.language.load import load_scenario
from orchestrator.language.success import typed_success
from orchestrator.world import World
from orchestrator.world.randomization import object_poses


@pytest.fixture(scope="module")
def world() -> World:
    return World.build(load_scenario("stack").scenario, seed=3)


def _ctx(world: World, **values) -> Context:
    ctrl = Controller(world.robot, float(world.model.opt.timestep))
    return Context(Cell(world, ctrl, 0), Blackboard(values))


def _move(ctx: Context, name: str, dx: float) -> None:
    adr = ctx.world.objects[name].qpos_adr
    ctx.data.qpos[adr] += dx
    mujoco.mj_forward(ctx.model, ctx.data)


def test_start_pose_is_where_the_object_began_wherever_it_is_now(world):
    ctx = _ctx(world)
    drawn = {name: pos for name, pos, _ in object_poses(ctx.scenario, 3)}
    before = ctx.start_pose("top")
    assert np.allclose(before.pos, drawn["top"])
    _move(ctx, "top", 0.02)
    assert ctx.object_pose("top").pos[0] == pytest.approx(before.pos[0] + 0.02)
    assert np.allclose(ctx.start_pose("top").pos, before.pos)  # where it started, still
    _move(ctx, "top", -0.02)
    with pytest.raises(SkillError, match="base"):  # an unknown name lists the valid ones
        ctx.start_pose("tpo")


def test_key_parameters_are_read_from_the_blackboard_and_validated_then(world):
    start = _ctx(world).start_pose("top").pos
    checks = typed_success(
        {"near": {"kind": "object_at", "object": "$what", "target": start, "xy_tol_m": "$tol"}}
    )
    ctx = _ctx(world, what="top", tol=0.004)
    _move(ctx, "top", 0.003)
    ok, detail = evaluate(ctx, checks)["near"]
    assert ok, detail
    assert "top" in detail and "3.0 mm" in detail
    assert errors(ctx, checks)["near_xy_error_mm"] == pytest.approx(3.0, abs=0.01)
    ctx.blackboard["tol"] = 0.002  # the same entry, judged with what the blackboard now says
    ok, detail = evaluate(ctx, checks)["near"]
    assert not ok and "xy_tol_m 2 mm" in detail
    _move(ctx, "top", -0.003)


def test_a_key_parameter_the_check_cannot_take_fails_the_check_saying_why(world):
    checks = typed_success(
        {"near": {"kind": "object_at", "object": "top", "target": [0.5, 0.0, 0.2],
                  "xy_tol_m": "$tol"}}
    )  # fmt: skip
    ok, detail = evaluate(_ctx(world, tol="wide"), checks)["near"]
    assert not ok and "xy_tol_m" in detail and "'wide'" in detail and "$tol" in detail
    ok, detail = evaluate(_ctx(world), checks)["near"]  # the key was never written
    assert not ok and "$tol" in detail
    assert errors(_ctx(world), checks) == {}


MACHINE = """\
name: look
initial: LOOK
blackboard:
  object: {type: str, default: cube}
  tolerance: {type: float, default: 0.02}
states:
  LOOK:
    skill: search
    with: {object: $object}
    transitions: {found: DONE, not_found: FAILED}
  DONE: {final: succeeded}
  FAILED: {final: failed}
"""


def _scenario(tmp_path, success: str):
    (tmp_path / "m.yaml").write_text(MACHINE)
    path = tmp_path / "s.yaml"
    path.write_text(
        "name: s\nmachine: m.yaml\n"
        "scene:\n  objects:\n    - {name: cube, size: [0.05, 0.05, 0.05], xy: [0.5, 0.0]}\n"
        f"success:\n  stayed: {success}\n"
    )
    return path


def test_a_key_parameter_must_name_a_blackboard_key_and_is_read_at_the_end(cli, tmp_path):
    typo = _scenario(tmp_path, "{kind: object_at, object: $object, target: [0.5, 0.0, 0.2], "
                               "xy_tol_m: $tolerence}")  # fmt: skip
    res = cli("validate", str(typo))
    assert res.exit_code == 2 and "tolerence" in res.stderr and "tolerance" in res.stderr
    bad = _scenario(tmp_path, "{kind: object_at, object: $object, target: [0.5, 0.0, 0.2], "
                              "xy_tol_m: -1}")  # fmt: skip
    assert cli("validate", str(bad)).exit_code == 2  # the others are validated as before
    good = _scenario(tmp_path, "{kind: object_at, object: $object, target: [0.51, 0.0, 0.2], "
                               "xy_tol_m: $tolerance}")  # fmt: skip
    assert cli("validate", str(good)).exit_code == 0
    wide = cli("run", str(good), "--json")  # the cube stays 10 mm from the target: 20 mm ok
    assert wide.json["success"]["stayed"] is True, wide.json["success_detail"]
    narrow = cli("run", str(good), "--json", "--set", "tolerance=0.005")
    assert narrow.json["success"]["stayed"] is False
    assert "xy_tol_m 5 mm" in narrow.json["success_detail"]["stayed"]
