"""PICK x y z: a position hint picks what is nearest it, and nothing when nothing is near."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from orchestrator.skills import get_skill

from orchestrator.engine.blackboard import Blackboard
from orchestrator.engine.cell import Cell
from orchestrator.engine.context import Context
from orchestrator.engine.episode import make_controller
from orchestrator.language.load import load_scenario
from orchestrator.live.protocol import Command
from orchestrator.live.session import Session
from orchestrator.world import World


def world_context(scenario: str, seed: int = 0):
    """A context on the world of `scenario` (no episode), its kinematics computed."""
    loaded = load_scenario(scenario)
    world = World.build(loaded.scenario, seed)
    mujoco.mj_forward(world.model, world.data)
    return Context(Cell(world, make_controller(world, seed), seed), Blackboard({}))


def _perceive(ctx, skill: str, **params) -> str:
    cls = get_skill(skill)
    s = cls(cls.Params.model_validate({"duration_s": 0.0, **params}))
    s.start(ctx)
    outcome = s.step(ctx)
    assert outcome is not None
    return outcome


@pytest.fixture(scope="module")
def vision():
    return world_context("pick_place_vision")


def test_detect_with_a_hint_reports_the_detection_nearest_it(vision):
    green = vision.object_pose("green_cube").pos
    hint = [green[0] + 0.02, green[1] - 0.01, 0.2]  # 22 mm off, on the table top
    outcome = _perceive(vision, "detect", camera="overhead", near=hint, pose_into="object_pose")
    assert outcome == "found"
    seen = vision.blackboard["object_pose"].pos
    assert np.hypot(seen[0] - green[0], seen[1] - green[1]) < 0.003  # the green cube's
    best = _perceive(
        vision, "detect", camera="overhead", pose_into="object_pose", **{"class": "red"}
    )
    assert best == "found"  # without a hint: the first confident detection of its class
    red = vision.object_pose("cube").pos
    seen = vision.blackboard["object_pose"].pos
    assert np.hypot(seen[0] - red[0], seen[1] - red[1]) < 0.003


def test_detect_with_a_hint_far_from_everything_reports_none(vision):
    outcome = _perceive(vision, "detect", camera="overhead", near=[0.8, 0.35, 0.2])
    assert outcome == "none"


def test_search_with_a_hint_finds_the_object_only_near_it():
    ctx = world_context("pick_place", seed=3)
    cube = ctx.object_pose("cube").pos
    near = [cube[0] + 0.03, cube[1], 0.2]
    assert _perceive(ctx, "search", object="cube", near=near) == "found"
    far = [cube[0] + 0.06, cube[1], 0.2]
    assert _perceive(ctx, "search", object="cube", near=far) == "not_found"
    wide = {"near": far, "near_radius_m": 0.07}
    assert _perceive(ctx, "search", object="cube", **wide) == "found"


def test_pick_x_y_z_over_the_channel_picks_the_cube_there():
    session = Session("pick_place", "pick", seed=3, speed=0.0)
    cube = session.ctx.object_pose("cube").pos
    at = [round(cube[0] + 0.02, 3), round(cube[1] - 0.02, 3), 0.2]
    reply = session.submit(Command(op="run", machine="pick_place", set=[f"pick_at={at}"]))
    assert reply.accepted, reply.reason
    session._drain()
    session._start_next()
    for _ in range(3000):
        session._tick()
        if session.task is None:
            break
    result = session.last_result
    assert result["outcome"] == "succeeded" and result["final_state"] == "DONE"
