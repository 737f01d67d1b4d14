"""The grasp's guarded final approach (issue 42, third round): with the search's noise at its
validated bound (1 cm, 5 deg) a finger comes down on the object's top. It used to land at
approach speed (joint 2 at 1.03-2.2x its datasheet acceleration, guard abort); now the last
centimetres around the object's top are slow and watched by the wrist force, the hand backs
off on the touch and the flow looks again, or ends with a reason naming the contact."""

from __future__ import annotations

import pytest

from orchestrator.engine.runner import run_episode
from orchestrator.language.load import load_scenario

NOISE = ["perception.position_noise_m=0.01", "perception.yaw_noise_deg=5"]


def _touches(result) -> list[dict]:
    return [
        t
        for t in result.transitions
        if t["from"].endswith("GRASP.TOUCH") and t["trigger"] == "contact"
    ]


@pytest.mark.parametrize(
    ("scenario", "seed"),
    [
        ("pick_place", 1),  # a finger on the cube, then a fresh look and the grasp
        ("pick_place", 0),  # on the cube three times: fails, naming the contact
        ("stack", 0),
        ("pick_place_ur5", 4),
        ("pick_place_so101", 1),
    ],
)
def test_a_finger_on_the_object_s_top_is_felt_slowly_and_backed_off(scenario, seed):
    result = run_episode(load_scenario(scenario, NOISE), seed)
    touches = _touches(result)
    assert touches, [(t["from"], t["trigger"]) for t in result.transitions]
    # the watch's reading is the transition's detail: the force felt and the threshold
    assert all("N at the wrist" in t.get("detail", "") for t in touches), touches
    assert result.invariants["ok"], result.invariants["violations"]
    assert result.invariants["worst"]["joint_acceleration"] <= 1.0
    if result.outcome != "succeeded":
        assert result.outcome == "failed", result.reason
        message = result.reason["message"]
        assert "TOUCH" in message or "contact" in message, message
        assert "unexpected contact" in message, message


def test_the_nominal_pick_passes_the_guarded_stretch_without_a_touch():
    # the slow stretch is around the cube's top only: a centred hand feels nothing there
    result = run_episode(load_scenario("pick_place"), 0)
    assert result.outcome == "succeeded", result.reason
    states = [t["from"] for t in result.transitions]
    assert "PICK.GRASP.TOUCH" in states and "PICK.GRASP.CLOSE_IN" in states
    assert not _touches(result)
