"""Parcel sorting: the scene, the task skills, the task log and its verdicts, the batch sums."""

from __future__ import annotations

import json
import math
import re
import shutil
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from orchestrator.skills import get_skill

from orchestrator.batch.summary import summarize
from orchestrator.engine.blackboard import Blackboard
from orchestrator.engine.runner import run_episode
from orchestrator.exceptions import ConfigError
from orchestrator.language.load import load_scenario
from orchestrator.language.parcels import SAME_CLASS_GAP_M, draw_parcels
from orchestrator.world.footprint import separated

REPO = Path(__file__).resolve().parents[1]


class _Tasks:
    """Records what the task skills report (the engine's TaskLog needs a world)."""

    def __init__(self) -> None:
        self.calls: list[tuple] = []

    def begin(self, ctx, task, detected, pos):
        self.calls.append(("begin", task, detected))

    def attempt(self, ctx, task, attempt):
        self.calls.append(("attempt", task, attempt))

    def end(self, ctx, task, flow, reason=None, bin=None):
        self.calls.append(("end", task, flow, reason))


def _ctx(**values):
    return SimpleNamespace(
        blackboard=Blackboard(values),
        tasks=_Tasks(),
        clock=0.0,
        t=0.0,
        events=[],
        tcp_pos=np.array([0.5, 0.25, 0.4]),
        log=lambda *a, **k: None,
    )


def _det(cls: str, x: float, y: float, confidence: float = 1.0) -> dict:
    return {"class": cls, "pose": {"pos": [x, y, 0.24], "quat": [1, 0, 0, 0]},
            "confidence": confidence}  # fmt: skip


def _run(skill: str, ctx, **params) -> str:
    cls = get_skill(skill)
    s = cls(cls.Params.model_validate(params))
    s.start(ctx)
    return s.step(ctx)


def _next(ctx, items, **kw) -> str:
    return _run("next_task", ctx, items=items, priority=["A", "B", "C"], pose_into="pose", **kw)


def test_next_task_serves_by_priority_then_nearest_and_ignores_unsure_or_unlisted_items():
    items = [_det("C", 0.5, -0.1), _det("B", 0.6, -0.3), _det("B", 0.5, -0.1),
             _det("A", 0.4, -0.2, confidence=0.3), _det("X", 0.5, -0.05)]  # fmt: skip
    ctx = _ctx()
    assert _next(ctx, items, nearest_to=[0.5, 0.0, 0.2]) == "next"
    task = ctx.blackboard["task"]
    assert (task["class"], task["pose"]["pos"][:2], task["task"], task["attempt"]) == (
        "B", [0.5, -0.1], 1, 1)  # fmt: skip
    assert ctx.blackboard["pose"].pos[:2] == [0.5, -0.1]
    assert _run("end_task", ctx, outcome="done", bin="bin_B") == "ended"
    assert ctx.blackboard["schedule"]["done"] == 1
    # without nearest_to the hand decides: (0.5, 0.25) is nearer to (0.6, -0.3)? no: (0.5, -0.1)
    ctx2 = _ctx()
    _next(ctx2, [_det("B", 0.6, -0.3), _det("B", 0.5, -0.1)])
    assert ctx2.blackboard["task"]["pose"]["pos"][:2] == [0.5, -0.1]
    assert _next(_ctx(), [_det("X", 0.5, 0.0)]) == "empty"


def test_a_failed_task_is_retried_recentred_then_rejected_and_its_item_left_alone():
    ctx = _ctx()
    assert _next(ctx, [_det("A", 0.50, -0.10), _det("B", 0.4, -0.3)], max_attempts=2) == "next"
    _run("end_task", ctx, outcome="failed", reason="grasp missed")
    # seen again 1 cm away: the same task, attempt 2, re-centred on the new detection
    assert _next(ctx, [_det("A", 0.51, -0.10), _det("B", 0.4, -0.3)], max_attempts=2) == "next"
    task = ctx.blackboard["task"]
    assert (task["task"], task["attempt"], task["pose"]["pos"][0]) == (1, 2, 0.51)
    _run("end_task", ctx, outcome="failed", reason="grasp missed")
    # out of attempts: rejected, and the next task is the B parcel
    assert _next(ctx, [_det("A", 0.51, -0.10), _det("B", 0.4, -0.3)], max_attempts=2) == "next"
    assert ctx.blackboard["task"]["class"] == "B"
    rejected = ctx.blackboard["schedule"]["rejected"]
    assert [r["class"] for r in rejected] == ["A"]
    assert "2 failed attempts" in rejected[0]["reason"]
    _run("end_task", ctx, outcome="done")
    assert _next(ctx, [_det("A", 0.51, -0.10)]) == "empty"  # the rejected one stays alone
    assert ("end", 1, "rejected", rejected[0]["reason"]) in ctx.tasks.calls
    assert ("attempt", 1, 2) in ctx.tasks.calls


def test_a_task_whose_item_is_gone_is_dropped_as_lost_and_rejecting_needs_a_reason():
    ctx = _ctx()
    _next(ctx, [_det("A", 0.5, -0.1)])
    _run("end_task", ctx, outcome="failed")
    assert _next(ctx, []) == "empty"
    assert ctx.tasks.calls[-1][:3] == ("end", 1, "lost")
    with pytest.raises(ValueError, match="a rejected task needs a `reason`"):
        get_skill("end_task").Params.model_validate({"outcome": "rejected"})


def test_every_schedule_ends_within_its_attempt_budget():
    """A flow that fails every grasp still ends: each item costs at most max_attempts."""
    items = [_det(c, 0.4 + 0.1 * i, -0.2) for i, c in enumerate("ABCAB")]
    ctx, passes = _ctx(), 0
    while _next(ctx, items, max_attempts=3) == "next":
        _run("end_task", ctx, outcome="failed", reason="grasp missed")
        passes += 1
        assert passes <= len(items) * 3
    assert passes == len(items) * 3
    assert len(ctx.blackboard["schedule"]["rejected"]) == len(items)


def test_a_deferred_task_waits_until_nothing_else_is_left_then_is_retried_or_rejected():
    ctx = _ctx()
    items = [_det("A", 0.50, -0.10), _det("B", 0.40, -0.30)]
    assert _next(ctx, items, max_attempts=2) == "next"
    assert ctx.blackboard["task"]["class"] == "A"
    _run("end_task", ctx, outcome="deferred", reason="blocked: a neighbour")
    # A first by priority, but deferred: B is served, then A again (attempt 2, task 1)
    assert _next(ctx, items, max_attempts=2) == "next"
    assert ctx.blackboard["task"]["class"] == "B"
    _run("end_task", ctx, outcome="done")
    assert _next(ctx, [items[0]], max_attempts=2) == "next"
    task = ctx.blackboard["task"]
    assert (task["class"], task["task"], task["attempt"]) == ("A", 1, 2)
    _run("end_task", ctx, outcome="deferred", reason="blocked: still")
    # out of attempts: rejected with the last reason, and nothing is left
    assert _next(ctx, [items[0]], max_attempts=2) == "empty"
    reason = ctx.blackboard["schedule"]["rejected"][0]["reason"]
    assert reason == "2 failed attempts (max_attempts 2), the last: blocked: still"
    assert ("end", 1, "rejected", reason) in ctx.tasks.calls


def test_a_deferred_task_whose_item_is_gone_ends_lost():
    ctx = _ctx()
    _next(ctx, [_det("A", 0.5, -0.1)])
    _run("end_task", ctx, outcome="deferred", reason="blocked")
    assert _next(ctx, []) == "empty"
    assert ctx.tasks.calls[-1][:3] == ("end", 1, "lost")
    assert ctx.blackboard["schedule"]["deferred"] == []


def test_end_task_puts_the_detail_of_the_failed_state_into_its_reason():
    ctx = _ctx()
    _next(ctx, [_det("A", 0.5, -0.1)])
    detail = "the IK gets 38.2 mm from it"
    ctx.events.append(
        SimpleNamespace(t=0.0, kind="transition", data={"transition": {"detail": detail}})
    )
    ctx.events.append(SimpleNamespace(t=0.0, kind="transition", data={"transition": {}}))
    _run("end_task", ctx, outcome="rejected", reason="out of reach: {detail}")
    assert ctx.blackboard["schedule"]["rejected"][0]["reason"] == f"out of reach: {detail}"


def test_lookup_branches_on_a_value_through_a_table():
    ctx = _ctx()
    table = {"A": "bin_A", "B": "bin_B"}
    assert _run("lookup", ctx, table=table, key="B", into="bin") == "found"
    assert ctx.blackboard["bin"] == "bin_B"
    assert _run("lookup", ctx, table=table, key="C", into="bin") == "missing"
    spots = [[1, 0, 0], [0, 1, 0], [0, 0, 1]]
    assert _run("lookup", ctx, table=spots, key=4, wrap=True, into="spot") == "found"
    assert ctx.blackboard["spot"] == [0, 1, 0]  # taking turns: 4 mod 3
    assert _run("lookup", ctx, table=spots, key=4, into="spot") == "missing"


@pytest.fixture(scope="module")
def sorting():
    return load_scenario("sorting")


def test_parcels_are_drawn_per_seed_inside_the_area_apart_or_touching_another_class(sorting):
    p = sorting.scenario.scene.parcels
    assert p is not None
    touching = 0
    for seed in range(20):
        drawn = draw_parcels(p, seed)
        assert drawn == draw_parcels(p, seed)  # same seed, same parcels
        assert len(drawn) == p.count
        boxes = [(x, y, yaw, s[0] / 2, s[1] / 2) for _, (_, s, _, x, y, yaw) in drawn]
        for _, (cls, size, mass, x, y, _) in drawn:
            assert cls in p.classes
            assert p.length_m[0] <= size[0] <= p.length_m[1]
            assert p.width_m[0] <= size[1] <= p.width_m[1]
            assert p.mass_kg[0] <= mass <= p.mass_kg[1]
            assert abs(x - p.area_center_xy[0]) <= p.area_size_xy[0] / 2
            assert abs(y - p.area_center_xy[1]) <= p.area_size_xy[1] / 2
        for i in range(len(boxes)):
            for j in range(i):
                if separated(boxes[i], boxes[j], p.gap_m - 1e-9):
                    continue
                assert separated(boxes[i], boxes[j], 0.0)  # closer than gap_m only if touching
                d = math.hypot(boxes[i][0] - boxes[j][0], boxes[i][1] - boxes[j][1])
                assert d == pytest.approx(boxes[i][3] + boxes[j][3] + 0.0005, abs=1e-6)
                assert drawn[i][1][0] != drawn[j][1][0]
                touching += 1
    assert touching >= 5  # some parcels touch


@pytest.mark.parametrize(
    "seeds",
    [range(5), pytest.param(range(5, 20), marks=pytest.mark.slow)],  # ~0.5 s a seed
    ids=["seeds0-4", "seeds5-19"],
)
def test_single_class_parcels_fit_and_one_class_never_touches(sorting, seeds):
    p = sorting.scenario.scene.parcels
    one = p.model_copy(update={"classes": {"A": [0.85, 0.15, 0.15, 1.0]}})
    flush = p.model_copy(update={"gap_m": 0.0})
    for seed in seeds:
        drawn = draw_parcels(one, seed)  # random layouts fill ~60 %: then a grid
        assert len(drawn) == 8
        boxes = [(x, y, yaw, s[0] / 2, s[1] / 2) for _, (_, s, _, x, y, yaw) in drawn]
        assert all(separated(a, b, one.gap_m - 1e-9) for i, a in enumerate(boxes)
                   for b in boxes[:i])  # fmt: skip
        # gap_m 0: parcels of one class still keep 1 cm (one colour touching is one blob)
        flat = draw_parcels(flush, seed)
        for i, (_, (ci, si, _, xi, yi, ai)) in enumerate(flat):
            for _, (cj, sj, _, xj, yj, aj) in flat[:i]:
                if ci == cj:
                    a = (xi, yi, ai, si[0] / 2, si[1] / 2)
                    b = (xj, yj, aj, sj[0] / 2, sj[1] / 2)
                    assert separated(a, b, SAME_CLASS_GAP_M - 1e-9)


def test_touching_that_can_never_be_laid_out_is_refused_naming_the_limit(cli):
    res = cli("validate", "sorting")  # the bundled one is fine
    assert res.exit_code == 0
    bad = cli("run", "sorting", "--set", "scene.parcels.touching=1.0")
    assert bad.exit_code == 2
    assert "scene.parcels.touching: touching 1.0 with 8 parcels can never be laid out" in bad.stderr
    assert "holds at most 7 parcels" in bad.stderr and "(valid: touching < 1" in bad.stderr


def test_too_many_parcels_for_the_area_is_a_clear_error(sorting):
    p = sorting.scenario.scene.parcels.model_copy(update={"count": 60})
    with pytest.raises(ConfigError, match="cannot place 60 parcels in the pick area") as err:
        draw_parcels(p, 0)
    # the most any random layout placed, and what the grid holds
    assert "random layouts, and a grid of 3 x 3 cells holds 9" in str(err.value)


def test_set_parcels_sets_the_count_and_bins_are_markers_with_walls():
    loaded = load_scenario("sorting", ["parcels=3"])
    scene = loaded.scenario.scene
    assert scene.parcels.count == 3
    assert {"bin_A", "bin_B", "bin_C"} <= {m.name for m in scene.markers}
    assert sum(o.name.startswith("bin_A_wall") for o in scene.obstacles) == 4


def test_a_flow_reading_a_wrong_type_into_next_task_is_a_located_error(tmp_path, cli):
    for name in ("sorting.yaml", "grasp.yaml", "home.yaml"):
        shutil.copy(REPO / "machines" / name, tmp_path / name)
    shutil.copy(REPO / "scenarios" / "sorting.yaml", tmp_path / "scn.yaml")
    text = (tmp_path / "scn.yaml").read_text().replace("machine: sorting", "machine: sorting.yaml")
    (tmp_path / "scn.yaml").write_text(text)
    flow = (tmp_path / "sorting.yaml").read_text()
    (tmp_path / "sorting.yaml").write_text(flow.replace("items: $detections", "items: $camera"))
    res = cli("validate", str(tmp_path / "scn.yaml"))
    assert res.exit_code == 2
    out = res.stdout + res.stderr
    assert "sorting.yaml:" in out and "states.SCHEDULE.with.items" in out
    assert "`$camera` is a str" in out
    (tmp_path / "sorting.yaml").write_text(flow.replace("key: $task.class", "key: $tsk.class"))
    res = cli("validate", str(tmp_path / "scn.yaml"))
    assert res.exit_code == 2
    assert "`$tsk` reads a blackboard key that is never declared" in res.stdout + res.stderr


def _one(overrides: list[str], faults: list[str] | None = None, seed: int = 3):
    return run_episode(load_scenario("sorting", ["parcels=1", *overrides], faults or []), seed)


def test_one_parcel_is_sorted_into_the_bin_of_its_class_and_logged():
    r = _one([])
    assert r.outcome == "succeeded", r.success_detail
    (task,) = r.tasks
    assert task["outcome"] == "sorted" and task["attempts"] == 1
    assert task["bin"] == f"bin_{task['class']}" and task["detected_class"] == task["class"]
    assert task["start_t"] < task["end_t"] < r.sim_time
    m = r.metrics
    assert (m["parcels"], m["sorted"], m["missorted"]) == (1, 1, 0)
    assert m["parcels_per_hour"] > 0 and m["parcel_cycle_s"]["p50"] == pytest.approx(
        task["end_t"] - task["start_t"], abs=1e-3)  # fmt: skip
    assert json.loads(json.dumps(r.to_json_dict()))["tasks"] == r.tasks


def test_a_parcel_in_a_wrong_bin_fails_the_run_as_missorted():
    r = _one(["bins={A: bin_B, B: bin_C, C: bin_A}"])
    assert r.outcome == "failed"
    (task,) = r.tasks
    assert task["outcome"] == "missorted" and r.metrics["missorted"] == 1
    assert "missorted" in r.success_detail["all_sorted"]


def test_a_slipping_grasp_is_retried_on_a_new_detection_then_rejected():
    r = _one([], ["slip:object=parcel_00,factor=0.01@PICK.LIFT"])
    (task,) = r.tasks
    assert task["attempts"] == 2, r.transitions
    assert task["outcome"] == "rejected"
    assert "2 failed attempts" in task["reason"]
    assert r.outcome == "succeeded"  # rejected with a reason counts as accounted for
    assert sum(1 for t in r.transitions if t["to"] == "MISSED") == 2


def test_a_parcel_out_of_reach_is_rejected_at_once():
    r = _one(["robot.base_pos=[-0.15, 0.0, 0.0]", "scene.parcels.area_center_xy=[0.66, -0.38]",
              "scene.parcels.area_size_xy=[0.09, 0.09]"])  # fmt: skip
    (task,) = r.tasks
    assert (task["outcome"], task["attempts"]) == ("rejected", 1)
    # the IK's dry run of the grasp pose, before anything moves: its residual is the reason
    found = re.fullmatch(r"out of reach: .*IK gets only within ([\d.]+) mm .*", task["reason"])
    assert found and float(found.group(1)) > 5.0, task["reason"]
    assert "PICK.APPROACH" not in [t["to"] for t in r.transitions]  # rejected at once
    assert task["end_t"] - task["start_t"] < 0.1
    assert r.outcome == "succeeded"


def test_the_batch_summary_adds_up_parcels_over_episodes():
    def line(seed, outcome, sorted_, rejected=0, dropped=0, missorted=0):
        n = sorted_ + rejected + dropped + missorted
        m = {"parcels": n, "sorted": sorted_, "rejected": rejected, "dropped": dropped,
             "missorted": missorted, "unsorted": 0}  # fmt: skip
        return {"seed": seed, "outcome": outcome, "sim_time": 30.0, "metrics": m}

    lines = [line(0, "succeeded", 8), line(1, "succeeded", 7, rejected=1),
             line(2, "failed", 6, dropped=1, missorted=1),
             {"seed": 3, "outcome": "error"}]  # fmt: skip
    s = summarize(lines, scenario="sorting", scenario_ref="sorting", overrides=[], seed_base=0,
                  backend="local", workers=1, wall_time_s=1.0, episodes_run=4,
                  results=Path("r"), rrd_dir=None).sorting  # fmt: skip
    assert s is not None
    assert (s.parcels, s.sorted, s.rejected, s.dropped, s.missorted) == (24, 21, 1, 1, 1)
    assert s.sort_rate == pytest.approx(21 / 24, abs=1e-6)
    lo, hi = s.sort_rate_ci95
    assert lo < 21 / 24 < hi
    assert s.parcels_per_hour == pytest.approx(21 / 90 * 3600, abs=0.1)


def test_the_recording_shows_the_task_log_as_it_grows(tmp_path):
    from .test_recording import record

    rec = record(load_scenario("sorting", ["parcels=2"]), 3, tmp_path / "sorting.rrd")
    rows = rec.temporal["/events/task"]
    texts = [t for row in rec.column("/events/task", "TextLog:text") for t in row]
    assert len(rows) >= 4  # begin and end of each task, then each parcel's verdict
    times = [r["sim_time"].total_seconds() for r in rows]
    assert times == sorted(times) and times[0] < times[-1]
    assert any("task 1: parcel_" in t for t in texts)
    assert sum(1 for t in texts if t.endswith(": sorted")) == 2, texts
