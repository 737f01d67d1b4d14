"""Loads over the arm's rated payload (issue 42, fourth round): explore drew 12.5-41 kg cubes
(the scene validates masses up to 100 kg); the arm lifted them until the `contact_force` guard
aborted, and the stop then jolted joint 6 past its deceleration. A cell knows its parts' masses:
the grasp planning now refuses an object heavier than the robot's rated payload leaves once the
hand on its flange is counted, before anything moves, naming the figures."""

from __future__ import annotations

import re

import pytest
from orchestrator.robots import SO101, UR5, Panda

from orchestrator.engine.runner import run_episode
from orchestrator.language.load import load_scenario


def _room(scenario: str) -> float:
    """What the robot's payload leaves for the object, read off the refusal's own figures."""
    heavy = run_episode(load_scenario(scenario, [_mass(scenario, 99.0)]), 0)
    found = re.search(r"at most ([0-9.]+) kg to carry", heavy.reason["message"])
    assert found, heavy.reason
    return float(found.group(1))


def _mass(scenario: str, kg: float) -> str:
    return f"scene.objects.cube.mass={kg}"


@pytest.mark.parametrize(
    ("scenario", "robot_cls"),
    [("pick_place", Panda), ("pick_place_ur5", UR5), ("pick_place_so101", SO101)],
)
def test_a_cube_over_the_rated_payload_is_refused_before_it_is_lifted(scenario, robot_cls):
    rated = robot_cls.payload_kg
    assert rated is not None and rated > 0.0
    result = run_episode(load_scenario(scenario, [_mass(scenario, rated + 1.0)]), 0)
    assert result.outcome == "failed", result.outcome
    reason = result.reason
    assert reason["state"].endswith("GRASP.PLAN"), reason
    message = reason["message"]
    assert f"is {rated + 1.0:.3g} kg" in message and f"rated payload of {rated:g} kg" in message
    assert "the hand's" in message, message
    # refused before the approach: the hand never went down, nothing was lifted
    states = [t["from"] for t in result.transitions]
    assert not any(s.endswith("GRASP.APPROACH") for s in states), states
    assert result.invariants["ok"], result.invariants["violations"]


@pytest.mark.parametrize("scenario", ["pick_place", "pick_place_ur5"])
def test_a_cube_just_under_what_the_payload_leaves_is_not_refused_for_its_mass(scenario):
    room = _room(scenario)
    result = run_episode(load_scenario(scenario, [_mass(scenario, round(room - 0.05, 2))]), 0)
    # it goes as before: carried, or ending with a reason; never an invariant violation
    assert result.invariants["ok"], result.invariants["violations"]
    if result.outcome != "succeeded":
        assert result.reason and result.reason["message"], result.reason
        assert "rated payload" not in result.reason["message"], result.reason
    states = [t["from"] for t in result.transitions]
    assert any(s.endswith("GRASP.APPROACH") for s in states), states


def test_mobile_search_names_the_payload_instead_of_retrying_a_block_it_cannot_lift():
    # a blocked grasp went to STOW and RECOVER, tried again from the same standoff and ended
    # "RECOVER ended `exhausted`": the cause (4 kg on a 3 kg arm) was in no reason
    rated = Panda.payload_kg
    result = run_episode(load_scenario("mobile_search", [_mass("mobile_search", 4.0)]), 0)
    assert result.outcome == "failed"
    assert result.reason["state"] == "GRASPING.PLAN", result.reason
    assert f"rated payload of {rated:g} kg" in result.reason["message"], result.reason
    assert result.invariants["ok"], result.invariants["violations"]
