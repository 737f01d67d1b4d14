"""The bundled pick-and-place scenario, end to end on physics."""

from __future__ import annotations

import pytest

from orchestrator.engine.result import RunResult
from orchestrator.engine.runner import run_episode
from orchestrator.language.load import load_scenario

SEEDS = list(range(10))


@pytest.fixture(scope="module")
def episode(pick_place):
    """The episode of a seed, run once for the tests of this module that only read it."""
    runs: dict[int, RunResult] = {}

    def get(seed: int) -> RunResult:
        if seed not in runs:
            runs[seed] = run_episode(pick_place, seed)
        return runs[seed]

    return get


@pytest.mark.parametrize("seed", SEEDS)
def test_pick_place_succeeds(episode, seed):
    result = episode(seed)
    assert result.outcome == "succeeded", result.transitions
    assert result.final_state == "DONE"
    assert result.success == {"cube_on_target": True, "gripper_clear": True}
    assert result.reason is None
    assert result.metrics["cycle_time"] <= 5.0
    states = [t["to"] for t in result.transitions]
    assert states[:5] == [
        "PICK.GRASP.PLAN",
        "PICK.GRASP.APPROACH",
        "PICK.GRASP.CLOSE",
        "PICK.GRASP.LIFT",
        "PICK.GRASP.VERIFY",
    ]
    assert states[-1] == "DONE"


def test_same_seed_gives_the_same_result_bit_for_bit(pick_place, episode):
    a = episode(7).to_json_dict()  # run before, other episodes in between: none leaks state
    b = run_episode(pick_place, 7).to_json_dict()
    a.pop("wall_time"), b.pop("wall_time")
    assert a == b


def test_different_seeds_place_the_cube_differently(episode):
    a = episode(1).transitions
    b = episode(2).transitions
    assert [t["t"] for t in a] != [t["t"] for t in b]


def test_missed_grasps_are_retried_then_the_run_fails():
    # the fingers close 12 cm beside the cube: every grasp closes on air
    loaded = load_scenario("pick_place", ["grasp_offset=[0.0, 0.12, 0.0]"])
    result = run_episode(loaded, 3)
    triggers = [(t["from"], t["to"], t["trigger"]) for t in result.transitions]
    assert result.outcome == "failed"
    assert result.final_state == "FAILED"
    assert result.retries == {"PICK": 2}
    assert ("PICK.GRASP.CLOSE", "PICK.GRASP.REOPEN", "missed") in triggers
    retried = [t for t in result.transitions if t.get("retry")]
    assert [t["retry"] for t in retried] == [1, 2]
    assert all(t["to"] == "PICK.SEARCH" for t in retried)


def test_physics_divergence_ends_the_run_failed_with_the_reason(pick_place):
    import mujoco

    class Diverge:
        """Raise MuJoCo's bad-velocity warning (MuJoCo resets the state itself on it)."""

        def on_start(self, ctx, executor):
            pass

        def on_tick(self, ctx, executor):
            if ctx.tick == 50:
                ctx.data.warning[mujoco.mjtWarning.mjWARN_BADQVEL].number = 1

        def on_end(self, ctx, executor, result):
            pass

    result = run_episode(pick_place, 0, [Diverge()])
    assert result.outcome == "failed"
    assert result.metrics["error"].startswith("physics diverged at t=0.5")
    assert result.success == {"cube_on_target": False, "gripper_clear": False}
