"""Rerun recording: what an episode's .rrd holds, read back with `rerun.chunk.RrdReader`."""

from __future__ import annotations

import os
import re
import socket
import subprocess
import sys
from collections import defaultdict
from dataclasses import dataclass, replace
from functools import cache
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
import pytest
import rerun as rr
from rerun.chunk import RrdReader

from orchestrator.engine.result import RunResult
from orchestrator.engine.runner import run_episode
from orchestrator.language.bundled import bundled_names
from orchestrator.language.load import LoadedScenario, load_machine, load_scenario
from orchestrator.language.machine import SAFE_STOP
from orchestrator.recording import (
    RecordingError,
    RerunRecorder,
    build_graph,
    geom_archetype,
    model_geometry,
    visible_geoms,
)
from orchestrator.recording.geometry_chunks import geometry_chunks
from orchestrator.recording.graph_drawing import ACCENT, EDGE_LABEL, IDLE
from orchestrator.recording.graph_layout import label_size
from orchestrator.recording.graph_views import COLLAPSED, label_id
from orchestrator.recording.machine_graph import GUARD, KIND_COLORS, LIT_MARK
from orchestrator.recording.state_log import StateLog
from orchestrator.recording.static_scene import static_scene
from orchestrator.recording.timeline import Rows, seconds_to_ns
from orchestrator.recording.viewer import connect_url, spawn_viewer
from orchestrator.world import World

ROW_ID = "rerun.controls.RowId"
IK_TARGET = "/world/targets/ik_target"
GEOMETRY = ("Mesh3D", "Boxes3D", "Capsules3D", "Cylinders3D", "Ellipsoids3D")


@dataclass
class Recording:
    """A recorded episode: its result and the rows of its .rrd, per entity, in log order."""

    path: Path
    result: RunResult
    temporal: dict[str, list[dict[str, Any]]]
    static: dict[str, dict[str, Any]]

    def column(self, entity: str, component: str) -> list[Any]:
        return [row[component] for row in self.temporal[entity] if component in row]


def read_rrd(path: Path) -> tuple[dict[str, list[dict]], dict[str, dict]]:
    """Every row of the recording store: temporal rows per entity in log (row id) order, and
    the static components per entity. Absent components and the row id are dropped."""
    temporal: dict[str, list[tuple[bytes, dict]]] = defaultdict(list)
    static_rows: dict[str, list[tuple[bytes, dict]]] = defaultdict(list)
    for chunk in RrdReader(path).stream().to_chunks():
        for raw in chunk.to_record_batch().to_pylist():
            row_id = raw.pop(ROW_ID)
            row = {k: v for k, v in raw.items() if v is not None}
            (static_rows if chunk.is_static else temporal)[chunk.entity_path].append((row_id, row))
    ordered = {e: [r for _, r in sorted(rows, key=lambda x: x[0])] for e, rows in temporal.items()}
    static: dict[str, dict] = defaultdict(dict)
    for entity, rows in static_rows.items():  # the last logged wins, as in the viewer: by row id
        for _, row in sorted(rows, key=lambda x: x[0]):
            static[entity].update(row)
    return ordered, dict(static)


def record(loaded: LoadedScenario, seed: int, path: Path, **kwargs: Any) -> Recording:
    recorder = RerunRecorder(path=path, **kwargs)
    result = run_episode(loaded, seed, [recorder])
    assert recorder.rec is None, "on_end closes the stream: the file is complete"
    temporal, static = read_rrd(path)
    return Recording(path, result, temporal, static)


@cache
def bundled_graph(name: str, use_dot: bool | None = None):
    """The graph of a bundled machine, laid out once for the tests that only read it (all the
    bundled machines' layouts: ~4.5 s CPU in Python and ~5 s in `dot`; `use_dot` as
    `build_graph`'s)."""
    return build_graph(load_machine(name), use_dot=use_dot)


@pytest.fixture(scope="module")
def blueprints_sent() -> list[dict]:
    """The keyword arguments of every blueprint the `recorded` episode sent."""
    return []


@pytest.fixture(scope="module")
def recorded(pick_place, tmp_path_factory, blueprints_sent) -> Recording:
    real = rr.RecordingStream.send_blueprint

    def send(self, bp, **kw):
        blueprints_sent.append(kw)
        return real(self, bp, **kw)

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(rr.RecordingStream, "send_blueprint", send)
        return record(pick_place, 0, tmp_path_factory.mktemp("rrd") / "seed0.rrd")


@pytest.fixture(scope="module")
def aborted(tmp_path_factory) -> Recording:
    loaded = load_scenario("pick_place", ["guards.workspace.max=[0.95, 0.1, 1.2]"])
    return record(loaded, 0, tmp_path_factory.mktemp("rrd") / "aborted.rrd")


# -- the acceptance checks ------------------------------------------------------------------
def test_state_changes_are_the_runs_transitions(recorded):
    transitions = recorded.result.transitions
    assert transitions, "pick_place makes transitions"
    states = [s[0] for s in recorded.column("/state_machine/active", "StateChange:state")]
    assert states == [transitions[0]["from"]] + [t["to"] for t in transitions]
    times = [r["sim_time"].total_seconds() for r in recorded.temporal["/state_machine/active"]]
    assert times == pytest.approx([0.0] + [t["t"] for t in transitions], abs=1e-9)


def test_one_geometry_entity_per_visible_geom(recorded, pick_place):
    model = World.build(pick_place.scenario, 0).model
    geometry = [
        e
        for e, comps in recorded.static.items()
        if any(c.split(":")[0] in GEOMETRY for c in comps) and e.startswith("/world/bodies/")
    ]
    proxies = {g for g in range(model.ngeom) if model.geom(g).name.endswith("_proxy")}
    assert proxies  # the self-collision capsules exist, hidden like MuJoCo's collision groups
    assert len(geometry) == len(visible_geoms(model)) == model.ngeom - len(proxies)
    meshes = [e for e in geometry if "Mesh3D:vertex_positions" in recorded.static[e]]
    n_mesh_geoms = int(np.sum(model.geom_type == mujoco.mjtGeom.mjGEOM_MESH))
    assert len(meshes) == n_mesh_geoms + 1  # + the floor plane, drawn as a quad
    floor = recorded.static["/world/bodies/world/geoms/floor"]
    assert len(floor["Mesh3D:vertex_positions"]) == 4


def test_body_transforms_vary_over_time(recorded):
    hand = recorded.temporal["/world/bodies/panda_hand"]
    ticks = [r["tick"] for r in hand]
    n = recorded.result.metrics["control_ticks"] + 1
    # a body is sent at the ticks it moved (by 0.1 mm or 1e-4 in a quaternion component)
    assert ticks[0] == 0 and ticks == sorted(set(ticks)) and 0.5 * n < len(ticks) <= n
    cube_ticks = [r["tick"] for r in recorded.temporal["/world/bodies/cube"]]
    assert len(cube_ticks) < 0.6 * n  # it rests until grasped, and on the pad
    xyz = np.array([r["Transform3D:translation"][0] for r in hand])
    assert np.ptp(xyz, axis=0).max() > 0.1  # the hand travels tens of centimetres
    cube = np.array(recorded.column("/world/bodies/cube", "Transform3D:translation"))[:, 0]
    assert not np.allclose(cube[0], cube[-1], atol=0.05)  # the cube was carried to the pad


def test_a_guard_violation_is_an_error_with_the_guards_name(aborted):
    assert aborted.result.outcome == "aborted"
    assert aborted.result.reason["guard"] == "workspace"
    rows = aborted.temporal["/events/violation"]
    assert [r["TextLog:level"] for r in rows] == [["ERROR"]]
    # the guard's margin is marked at the instant it fired, at 1.0 or above
    marks = aborted.temporal["/guards/workspace/tripped"]
    assert len(marks) == 1 and marks[0]["Scalars:scalars"][0] >= 1.0
    assert marks[0]["sim_time"].total_seconds() == pytest.approx(aborted.result.metrics["abort_t"])
    text = rows[0]["TextLog:text"][0]
    assert "workspace" in text
    assert "value" in text and "limit" in text
    assert str(aborted.result.reason["limit"]["bound"]) in text
    # the abort is a state change like any other, into the built-in safe stop
    states = [s[0] for s in aborted.column("/state_machine/active", "StateChange:state")]
    assert states[-1] == SAFE_STOP == aborted.result.transitions[-1]["to"]


def test_how_the_run_ended_is_a_static_document_shown_at_any_time(recorded, aborted):
    # static: the viewer shows it wherever the time cursor is, not only at the end
    for rec, words in ((recorded, ["succeeded"]), (aborted, ["aborted", "workspace"])):
        assert "/run/result" not in rec.temporal
        text = rec.static["/run/result"]["TextDocument:text"][0]
        assert all(w in text for w in words), text
        assert rec.result.final_state in text and "running" not in text


def test_same_seed_records_the_same_data(recorded, pick_place, tmp_path):
    again = record(pick_place, 0, tmp_path / "again.rrd")
    assert again.temporal == recorded.temporal
    assert again.static == recorded.static


# -- timelines, signals, events ---------------------------------------------------------------
def test_every_temporal_row_is_on_sim_time_and_tick_and_nothing_else(recorded):
    for entity, rows in recorded.temporal.items():
        for row in rows:
            timelines = {k for k in row if ":" not in k}
            assert timelines == {"sim_time", "tick"}, (entity, row)


def test_signals_are_sampled_every_control_tick(recorded):
    n = recorded.result.metrics["control_ticks"] + 1
    force = recorded.column("/signals/wrist_force_n", "Scalars:scalars")
    torque = recorded.column("/signals/joint_torque_nm", "Scalars:scalars")
    assert len(force) == len(torque) == n
    xyz = np.array(recorded.column("/signals/wrist_force_xyz_n", "Scalars:scalars"))
    assert {len(f) for f in force} == {2} and {len(t) for t in torque} == {7}
    f = np.array(force)
    assert len(xyz) == n and np.allclose(f[:, 0], np.linalg.norm(xyz, axis=1))
    # |F| samples the sensor per control tick; the second series is the peak of the true
    # force over every physics step, the very figure the run reports
    peak = recorded.result.metrics["max_wrist_force_n"]
    assert 0.5 * peak < max(f[:, 0]) <= peak + 0.05
    assert max(f[:, 1]) == pytest.approx(peak, abs=1e-4)
    width = np.array(recorded.column("/signals/gripper_width_m", "Scalars:scalars"))[:, 0]
    assert width.max() > 0.07 and width.min() < 0.06  # open, then closed on the 5 cm cube
    error = np.array(recorded.column("/signals/tcp_error_m", "Scalars:scalars"))[:, 0]
    assert 0 < len(error) < n and error.min() < 0.005 < error.max()
    names = recorded.static["/signals/joint_torque_nm"]["SeriesLines:names"]
    assert names == [f"panda_joint{i}" for i in range(1, 8)]


def test_each_guard_is_a_margin_against_the_trip_line_with_its_raw_value_beside(recorded):
    raw = np.array(recorded.column("/guard_values/contact_force", "Scalars:scalars"))
    assert len(raw) and set(raw[:, 1]) == {60.0}  # value and the scenario's max_n
    margin = np.array(recorded.column("/guards/contact_force", "Scalars:scalars"))[:, 0]
    # the margin is value / limit, or the peak of it over the tick's physics steps
    assert (margin >= raw[:, 0] / 60.0 - 1e-12).all() and margin.max() < 1.0
    for guard in ("workspace", "joint_limits", "joint_torque", "collision"):
        u = np.array(recorded.column(f"/guards/{guard}", "Scalars:scalars"))[:, 0]
        assert len(u) and (0.0 <= u).all() and (u < 1.0).all(), guard  # a safe run
    trip = np.array(recorded.column("/guards/trip", "Scalars:scalars"))[:, 0]
    times = [r["sim_time"].total_seconds() for r in recorded.temporal["/guards/trip"]]
    assert set(trip) == {1.0} and times[0] == 0.0 and times[-1] == recorded.result.sim_time


def test_events_are_text_logs_per_kind(recorded):
    transitions = recorded.temporal["/events/transition"]
    assert len(transitions) == len(recorded.result.transitions)
    assert all(r["TextLog:level"] == ["INFO"] for r in transitions)
    assert recorded.temporal["/events/outcome"]
    result = recorded.temporal["/events/result"]
    assert result[0]["TextLog:text"][0].startswith("succeeded in DONE")


def test_ik_target_is_a_frame_that_vanishes_between_motions(recorded):
    axes = [a[0] for a in recorded.column(IK_TARGET, "TransformAxes3D:axis_length")]
    assert axes[0] == 0.0 and max(axes) > 0.0 and 0.0 in axes[1:]
    pad = recorded.static["/world/targets/pad"]
    assert "Transform3D:translation" in pad and "TransformAxes3D:axis_length" in pad
    assert "Transform3D:translation" in recorded.static["/world/bodies/panda_hand/tcp"]


def _graph_rows(rec: Recording) -> list[tuple[str, list[str], list[str], list[int]]]:
    """Per state entry: the leaf, and the node ids, labels and colours the graph shows then
    (node ids are sent only at entries that open other machines: the last ones hold)."""
    rows = rec.temporal["/state_machine/graph"]
    layouts = iter([r["GraphNodes:node_ids"] for r in rows if "GraphNodes:node_ids" in r])
    entries = [r for r in rows if "GraphNodes:labels" in r]
    leaves = [rec.result.transitions[0]["from"]] + [t["to"] for t in rec.result.transitions]
    graph = build_graph(load_scenario(rec.result.scenario).machine)
    assert len(entries) == len(leaves)
    out, ids, shown = [], None, None
    for leaf, row in zip(leaves, entries, strict=True):
        if graph.expansion(leaf) != shown:
            ids, shown = next(layouts), graph.expansion(leaf)
        out.append((leaf, ids, row["GraphNodes:labels"], row["GraphNodes:colors"]))
    assert next(layouts, None) is None  # one layout per change of expansion, no more
    return out


def test_graph_lights_the_active_state_at_every_transition(recorded):
    for leaf, nodes, labels, colors in _graph_rows(recorded):
        lit = [n for n, label in zip(nodes, labels, strict=True) if label.startswith(LIT_MARK)]
        ancestors = [".".join(leaf.split(".")[: i + 1]) for i in range(leaf.count(".") + 1)]
        assert sorted(lit) == sorted(ancestors), leaf  # every ancestor shown, and lit
        shade = dict(zip(nodes, colors, strict=True))
        assert all(shade[n] in (ACCENT, KIND_COLORS["success"]) for n in lit)
        assert {shade[n] for n in nodes if n not in lit and "." not in n} <= {
            IDLE, EDGE_LABEL, *KIND_COLORS.values(),
        }  # fmt: skip


def test_only_the_machines_holding_the_active_leaf_are_open(recorded, pick_place):
    graph = build_graph(pick_place.machine)
    for leaf, nodes, labels, _ in _graph_rows(recorded):
        states = [n for n in nodes if n in graph.states]
        owners = {".".join(leaf.split(".")[:i]) for i in range(1, leaf.count(".") + 1)}
        for n in states:  # a state is shown only inside machines that are open
            assert all(
                p in owners
                for p in (".".join(n.split(".")[:i]) for i in range(1, n.count(".") + 1))
            ), (leaf, n)
        shut = [lab for n, lab in zip(nodes, labels, strict=True)
                if n in set(graph.regions.values()) - owners - {""}]  # fmt: skip
        assert all(lab.endswith(COLLAPSED) for lab in shut), shut


def test_edges_carry_their_outcomes_and_retries_loop(pick_place):
    graph = build_graph(pick_place.machine)
    view = graph.view("PICK.GRASP.CLOSE")
    texts = {view.labels[n] for n in view.edge_labels}
    assert "found" in texts  # PICK.SEARCH -> PICK.GRASP
    surgical = build_graph(load_scenario("surgical").machine).view("EXECUTE.TRACE")
    assert "EXECUTE" in surgical.labels and "guards: contact_force" in surgical.labels["EXECUTE"]
    mobile = build_graph(load_scenario("mobile_search").machine).view("SEARCHING.GO_2")
    loops = [(s, d) for s, d in mobile.edges if s == d]
    assert ("SEARCHING.SCAN_HERE", "SEARCHING.SCAN_HERE") in loops  # retry: 7
    assert mobile.labels[label_id(*loops[0])] == "retry 7"


def test_graph_reads_top_to_bottom_in_flow_order():
    for name in ("pick_place", "surgical"):
        graph = build_graph(load_scenario(name).machine)
        for view in graph.views.values():
            pos = view.layout.positions
            for src, dst in view.edges:
                if src in (dst, GUARD) or graph.states[dst].kind == "abort":
                    continue
                entry = dst.startswith(src + ".")
                exit_ = graph.states[src].region.startswith(graph.states[dst].region) and (
                    graph.states[src].region != graph.states[dst].region
                )
                if (entry or exit_) and pos[dst][1] == pos[src][1]:
                    # an open machine's title beside its initial state, or the state after a
                    # nested machine beside the final state it leaves from (graph_dot.py):
                    # the arrow runs sideways, from box to box
                    w = view.room(src)[0] + view.room(dst)[0]
                    assert abs(pos[dst][0] - pos[src][0]) >= w / 2, (name, src, dst)
                    continue
                assert pos[dst][1] > pos[src][1], (name, src, dst)


def test_final_states_lie_below_the_states_leading_to_them():
    # final states go into free room near the states leading to them, never above one
    arrows = 0
    for name in bundled_names("machines"):
        graph = bundled_graph(name)
        for view in graph.views.values():
            pos = view.layout.positions
            for src, dst in view.edges:
                if graph.states.get(dst) and graph.states[dst].kind in ("success", "final"):
                    if pos[dst][1] == pos[src][1] and graph.states[src].region != (
                        graph.states[dst].region
                    ):  # a nested machine's exit beside the final state it leaves from
                        w = view.room(src)[0] + view.room(dst)[0]
                        assert abs(pos[dst][0] - pos[src][0]) >= w / 2, (name, src, dst)
                        continue
                    assert pos[dst][1] > pos[src][1], (name, view.expanded, src, dst)
                    arrows += 1
    assert arrows > 250


@pytest.fixture(scope="module")
def layouts_per_hash_seed() -> list[list[str]]:
    """Two processes with different string hashes (and so object addresses), each printing the
    sorting_conveyor graph's views and the surgical graph's positions: one line each."""
    code = (
        "import json; from orchestrator.language.load import load_machine;"
        "from orchestrator.recording.machine_graph import build_graph;"
        "g = build_graph(load_machine('sorting_conveyor'));"
        "print(sorted((k, sorted(v.layout.positions.items())) for k, v in g.views.items()));"
        "print(json.dumps(build_graph(load_machine('surgical')).positions, sort_keys=True))"
    )
    return [
        subprocess.run(
            [sys.executable, "-c", code],
            env={**os.environ, "PYTHONHASHSEED": seed},
            capture_output=True, text=True, check=True,
        ).stdout.splitlines()
        for seed in ("1", "2")
    ]  # fmt: skip


def test_graph_layout_is_the_same_in_every_process(layouts_per_hash_seed):
    # string hashes (and so object addresses) differ between processes: the layout must not
    views = {lines[0] for lines in layouts_per_hash_seed}
    assert len(views) == 1 and "WAIT" in views.pop()


def test_nested_states_lie_inside_their_parents_frame():
    for name in ("pick_place", "surgical", "mobile_search"):
        graph = build_graph(load_scenario(name).machine)
        for view in graph.views.values():
            lay = view.layout
            for owner, (x0, y0, x1, y1) in lay.groups.items():
                inside = [n for n in view.states if n == owner or n.startswith(owner + ".")]
                assert len(inside) > 2, owner
                for n in inside:
                    (x, y), (w, h) = lay.positions[n], lay.sizes[n]
                    assert x0 <= x - w / 2 and x + w / 2 <= x1 and y0 <= y - h / 2, n
                    assert y + h / 2 <= y1, n


@pytest.mark.parametrize("name", ["pick_place", "surgical", "grasp", "mobile_search", "sorting"])
def test_state_labels_do_not_overlap_even_when_lit(name):
    graph = bundled_graph(name)
    lit_growth = label_size(LIT_MARK + "X")[0] - label_size("X")[0]
    for view in graph.views.values():
        boxes = []
        for n in view.states:
            (x, y), (w, h) = view.layout.positions[n], view.layout.sizes[n]
            w += lit_growth
            boxes.append((n, x - w / 2, y - h / 2, x + w / 2, y + h / 2))
        for i, a in enumerate(boxes):
            for b in boxes[i + 1 :]:
                overlap = a[1] < b[3] and b[1] < a[3] and a[2] < b[4] and b[2] < a[4]
                assert not overlap, (view.expanded, a[0], b[0])


def test_the_layouts_are_computed_once_per_machine_not_per_tick(monkeypatch, tmp_path):
    from orchestrator.recording import graph_views

    calls = []
    real = graph_views.dot_layout  # runs Graphviz's dot: never per tick, nor per physics step
    monkeypatch.setattr(graph_views, "dot_layout", lambda *a, **k: calls.append(1) or real(*a, **k))
    loaded = load_scenario("pick_place")  # a new machine object: its scene is built anew
    rec = record(loaded, 0, tmp_path / "a.rrd")
    n_views = len(build_graph(loaded.machine).views)
    assert len(calls) == 2 * n_views  # once for the recording, once for the check above
    record(loaded, 1, tmp_path / "b.rrd")  # the next episode reuses the static scene
    assert len(calls) == 2 * n_views
    # nodes, positions and arrows are sent only when another machine opens
    layouts = [r for r in rec.temporal["/state_machine/graph"] if "GraphNodes:positions" in r]
    expansions = [
        build_graph(loaded.machine).expansion(leaf)
        for leaf in [rec.result.transitions[0]["from"]] + [t["to"] for t in rec.result.transitions]
    ]
    changes = 1 + sum(a != b for a, b in zip(expansions, expansions[1:], strict=False))
    assert len(layouts) == changes < len(expansions)


def test_the_layout_is_the_same_in_every_process(layouts_per_hash_seed):
    positions = {lines[1] for lines in layouts_per_hash_seed}
    assert len(positions) == 1 and "SETUP.REGISTER" in positions.pop()


def test_each_nesting_depth_has_its_own_lane(recorded):
    top = [s[0] for s in recorded.column("/state_machine/levels/depth_0", "StateChange:state")]
    one = [s[0] for s in recorded.column("/state_machine/levels/depth_1", "StateChange:state")]
    two = [s[0] for s in recorded.column("/state_machine/levels/depth_2", "StateChange:state")]
    assert top[0] == "PICK" and top[-1] == "DONE"
    assert one[0] == "SEARCH" and "GRASP" in one and one[-1] == ""  # empty once PICK is left
    assert "CLOSE" in two and two[-1] == ""


def test_the_recording_opens_with_the_default_blueprint(recorded):
    reader = RrdReader(recorded.path)
    assert len(reader.recordings()) == 1
    assert len(reader.blueprints()) == 1


LONG_EPISODES = {
    "sorting", "sorting_conveyor", "sorting_ur5", "surgical", "surgical_complication",
    "pick_place_so101",
}  # fmt: skip
"""Scenarios whose episode takes 10-40 s (the surgical ones register by touch first), or whose
first 3 s cost ~7 s CPU (the SO-101's jaw): their recordings run with the slow suite."""
SHORT_S = 3.0
"""The simulated seconds the other scenarios' recordings run in the default suite [s]."""


@pytest.mark.parametrize(
    "name",
    [
        pytest.param(n, marks=pytest.mark.slow) if n in LONG_EPISODES else n
        for n in bundled_names("scenarios")
    ],
)
def test_every_bundled_scenario_records_its_transitions_and_geoms(name, tmp_path, request):
    if name == "pick_place":  # the module's recording of it (the same seed), to its end
        loaded, rec = load_scenario(name), request.getfixturevalue("recorded")
    else:
        # the first seconds are enough to see the states and the geoms recorded (the whole
        # episode: the long ones in the slow suite, pick_place's above); pick_place_so101 ran
        # 5.2 s simulated (~5 s CPU) in full, mobile_search 11.4 s
        cut = [] if name in LONG_EPISODES else [f"physics.time_limit_s={SHORT_S}"]
        loaded = load_scenario(name, cut)
        rec = record(loaded, 0, tmp_path / f"{name}.rrd")
    states = [s[0] for s in rec.column("/state_machine/active", "StateChange:state")]
    transitions = rec.result.transitions
    assert transitions, name  # the run got past its first state (reach_random has one)
    assert states == [transitions[0]["from"]] + [t["to"] for t in transitions]
    model = World.build(loaded.scenario, 0).model
    drawn = [e for e in rec.static if "/geoms/" in e]
    assert len(drawn) == len(visible_geoms(model))


def test_cli_rrd_writes_a_recording(cli, tmp_path):
    path = tmp_path / "nested" / "run.rrd"
    path.parent.mkdir()  # `--rrd` never creates a folder (a mistyped path is said)
    res = cli("run", "pick_place", "--seed", "1", "--rrd", str(path), "--json")
    assert res.exit_code == 0, res.stderr
    temporal, _ = read_rrd(path)
    assert "/state_machine/active" in temporal


# -- units --------------------------------------------------------------------------------------
ALL_GEOMS = """
<mujoco>
  <asset>
    <mesh name="tet" vertex="0 0 0  1 0 0  0 1 0  0 0 1"/>
    <hfield name="hill" nrow="3" ncol="4" size="1 1 0.5 0.1"/>
  </asset>
  <worldbody>
    <geom name="ground" type="plane" size="0 0 1"/>
    <geom name="terrain" type="hfield" hfield="hill"/>
    <body name="b" pos="0 0 1">
      <freejoint/>
      <geom name="box" type="box" size="0.1 0.2 0.3"/>
      <geom name="ball" type="sphere" size="0.1"/>
      <geom name="egg" type="ellipsoid" size="0.1 0.2 0.3"/>
      <geom name="pill" type="capsule" size="0.05 0.2"/>
      <geom name="can" type="cylinder" size="0.05 0.2"/>
      <geom name="tet" type="mesh" mesh="tet"/>
      <geom name="ghost" type="box" size="0.1 0.1 0.1" rgba="1 0 0 0"/>
      <geom name="hidden" type="box" size="0.1 0.1 0.1" group="3"/>
    </body>
  </worldbody>
</mujoco>
"""


def test_every_primitive_maps_to_its_archetype():
    model = mujoco.MjModel.from_xml_string(ALL_GEOMS)
    visible = [model.geom(g).name for g in visible_geoms(model)]
    assert visible == ["ground", "terrain", "box", "ball", "egg", "pill", "can", "tet"]
    kinds = {
        model.geom(g).name: type(geom_archetype(model, g)).__name__ for g in range(model.ngeom)
    }
    assert kinds == {
        "ground": "Mesh3D", "terrain": "Mesh3D", "box": "Boxes3D", "ball": "Ellipsoids3D",
        "egg": "Ellipsoids3D", "pill": "Capsules3D", "can": "Cylinders3D", "tet": "Mesh3D",
        "ghost": "Boxes3D", "hidden": "Boxes3D",
    }  # fmt: skip
    pill = geom_archetype(model, model.geom("pill").id)
    assert pill.lengths.as_arrow_array().to_pylist() == pytest.approx([0.4])
    assert pill.translations.as_arrow_array().to_pylist()[0] == pytest.approx([0, 0, -0.2])
    terrain = geom_archetype(model, model.geom("terrain").id)
    assert len(terrain.vertex_positions.as_arrow_array()) == 3 * 4
    assert len(terrain.triangle_indices.as_arrow_array()) == 2 * 2 * 3
    geoms, skipped = model_geometry(model)
    assert [g.entity for g in geoms][:2] == [
        "world/bodies/world/geoms/ground", "world/bodies/world/geoms/terrain",
    ]  # fmt: skip
    assert skipped == []


def test_geometry_chunks_are_cached_by_content(pick_place):
    a = geometry_chunks(World.build(pick_place.scenario, 1).model)
    b = geometry_chunks(World.build(pick_place.scenario, 2).model)  # other cube pose only
    assert a is b
    assert len(a.chunks) == len(visible_geoms(World.build(pick_place.scenario, 1).model))


def test_the_static_scene_is_shared_by_episodes_of_one_scenario(pick_place):
    scenes = []

    class Probe:
        def on_start(self, ctx, executor):
            scenes.append(static_scene(ctx, executor.root))

        def on_tick(self, ctx, executor):
            raise StopIteration  # enough: the scene is built before the first tick

        def on_end(self, ctx, executor, result):
            pass

    for loaded, seed in ((pick_place, 1), (pick_place, 2), (load_scenario("pick_place"), 1)):
        with pytest.raises(StopIteration):
            run_episode(loaded, seed, [Probe()])
    assert scenes[0] is scenes[1]  # another cube pose: same static scene
    assert scenes[2] is not scenes[0]  # another machine object: built anew
    assert len(scenes[2].chunks) == len(scenes[0].chunks)


def test_machine_graph_kinds_lanes_and_edges(pick_place):
    graph = build_graph(pick_place.machine)
    assert graph.states["DONE"].kind == "success"
    assert graph.states["FAILED"].kind == "final"
    assert graph.states[SAFE_STOP].color == KIND_COLORS["abort"]
    assert graph.states["PICK"].kind == "composite"
    assert graph.initial_leaf == "PICK.SEARCH"
    assert graph.lanes("PICK.SEARCH") == {"": "PICK", "PICK": "SEARCH"}
    assert graph.lanes(SAFE_STOP) == {"": SAFE_STOP}
    assert ("PICK", "PICK.SEARCH") in graph.edges  # entry into the nested machine
    assert (GUARD, SAFE_STOP) in graph.edges  # the abort path, from any state
    # out of a nested machine from the final states its outcomes come from
    assert ("PICK.PICKED", "TRANSPORT") in graph.edges
    assert ("PICK.GRASP.MISSED", "PICK.MISSED") in graph.edges
    assert not [e for e in graph.edges if e[0] in ("PICK", "PICK.GRASP") and "." not in e[1]]
    # every state is shown in the expansion of its own machine
    for path in graph.states:
        assert path in graph.view(path).states
    shut = graph.view("DONE")
    assert ("PICK", "TRANSPORT") in shut.edges  # the exits of a shut machine leave its node


def test_on_abort_state_is_the_abort_colour(write_yaml):
    path = write_yaml(
        "m.yaml",
        "name: m\ninitial: A\non_abort: HALT\nstates:\n"
        "  A: {skill: search, with: {object: cube}, transitions: {found: B, not_found: B}}\n"
        "  B: {final: succeeded}\n"
        "  HALT: {final: failed}\n",
    )
    from orchestrator.language.load import load_machine

    graph = build_graph(load_machine(str(path)))
    assert graph.states["HALT"].kind == "abort"
    assert SAFE_STOP not in graph.states
    assert (GUARD, "HALT") in graph.edges


def test_lanes_empty_when_the_leaf_is_shallower(pick_place):
    log = StateLog(build_graph(pick_place.machine))
    log.enter(0, 0.0, "PICK.SEARCH")
    log.enter(1, 0.01, "TRANSPORT")
    assert log._lanes[1] == [(0, 0.0, "SEARCH"), (1, 0.01, "")]
    assert log._lanes[0] == [(0, 0.0, "PICK"), (1, 0.01, "TRANSPORT")]


def test_rows_grow_and_times_round_to_nanoseconds():
    rows = Rows({"v": (2,)}, capacity=2)
    for k in range(5):
        i = rows.append(k, k * 0.01)
        rows.v[i] = [k, -k]
    ticks, t_s, values = rows.take()
    assert ticks.tolist() == [0, 1, 2, 3, 4] and values["v"][4].tolist() == [4, -4]
    assert len(rows) == 0
    assert seconds_to_ns([0.29, 2.07]).tolist() == [290_000_000, 2_070_000_000]


def test_a_recorder_needs_somewhere_to_record():
    with pytest.raises(RecordingError, match="path=<file.rrd>, spawn=True or connect=<url>"):
        RerunRecorder()
    with pytest.raises(RecordingError, match="flush_every_ticks"):
        RerunRecorder(path="x.rrd", flush_every_ticks=0)


def test_flushing_in_batches_records_the_same_rows(pick_place, recorded, tmp_path):
    batched = record(pick_place, 0, tmp_path / "batched.rrd", flush_every_ticks=7)

    def canonical(temporal: dict[str, list[dict]]) -> dict[str, list[dict]]:
        # batches interleave an entity's separately sent components differently; the rows
        # of one component keep their order (stable sort)
        # the trip line at 1.0 gets a point at every flush
        return {
            e: sorted(rs, key=lambda r: (r["tick"], sorted(r)))
            for e, rs in temporal.items()
            if e != "/guards/trip"
        }

    assert canonical(batched.temporal) == canonical(recorded.temporal)


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_spawn_viewer_tells_whether_a_viewer_listens(monkeypatch):
    monkeypatch.setattr(rr.RecordingStream, "spawn", lambda self, **kw: None)
    rec = rr.RecordingStream("test_viewer")
    assert not spawn_viewer(rec, _free_port(), timeout_s=0.1)
    with socket.socket() as server:
        server.bind(("127.0.0.1", 0))
        server.listen()
        assert spawn_viewer(rec, server.getsockname()[1], timeout_s=0.5)


def test_spawn_without_a_viewer_keeps_recording_to_the_file(monkeypatch, pick_place, tmp_path):
    monkeypatch.setattr(rr.RecordingStream, "spawn", lambda self, **kw: None)
    path = tmp_path / "live.rrd"
    recorder = RerunRecorder(path=path, spawn=True, port=_free_port())
    with pytest.warns(RuntimeWarning, match="no Rerun viewer came up"):
        result = run_episode(pick_place, 0, [recorder])
    temporal, _ = read_rrd(path)
    states = [r["StateChange:state"][0] for r in temporal["/state_machine/active"]]
    assert states[1:] == [t["to"] for t in result.transitions]


def test_spawn_without_a_viewer_or_a_file_is_an_error(monkeypatch, pick_place):
    monkeypatch.setattr(rr.RecordingStream, "spawn", lambda self, **kw: None)
    with pytest.raises(RecordingError, match="--rrd PATH"):
        run_episode(pick_place, 0, [RerunRecorder(spawn=True, port=_free_port())])


def test_recordings_use_their_own_stream_not_the_global_one(recorded):
    assert rr.get_global_data_recording() is None


def test_connect_takes_a_port_or_a_rerun_url():
    assert connect_url("9877") == "rerun+http://127.0.0.1:9877/proxy"
    url = "rerun+http://10.0.0.5:9876/proxy"
    assert connect_url(url) == url
    for bad in ("http://127.0.0.1:9876", "rerun+http://127.0.0.1:9876/", "localhost"):
        with pytest.raises(RecordingError, match=r"not a Rerun address \(valid: a port"):
            connect_url(bad)


def test_connect_to_nothing_is_an_error_naming_the_fix(cli):
    res = cli("run", "pick_place", "--connect", str(_free_port()))
    assert res.exit_code == 2
    message = " ".join(res.stderr.split())  # the console wraps long lines
    assert "no Rerun viewer or server at rerun+http://127.0.0.1:" in message
    assert "rerun --serve-web" in message and "--rrd PATH" in message


def test_every_sink_gets_the_blueprint_made_active(recorded, blueprints_sent):
    # a default-only blueprint loses to the layout a viewer guesses while data streams in
    # (rerun --serve-web, --connect): it must be made active
    assert blueprints_sent == [{"make_active": True, "make_default": True}]


def test_every_bundled_machine_is_legible_in_both_windows():
    from orchestrator.recording.blueprint import (
        LEGIBLE_ZOOM,
        WINDOWS,
        graph_zoom,
        machine_share,
    )  # fmt: skip

    # drawn whole, mobile_search was ~1550 px tall (labels ~5 px); sorting_conveyor was
    # 1274 px wide (zoom 0.45 at 1280x720) before long edges' bends stopped taking room, and
    # 962 x 818 px (zoom 0.59) with the grasp machine's recovery states before its final
    # states went into free room. dot's layout keeps room for each edge label: it showed
    # sorting_conveyor at 0.63 and three more machines at ~0.7 in the smaller window before
    # nested machines' exits could stay on their final state's rank, the guard pair went
    # into free room and a state's guards moved onto its name's line (graph_dot.py)
    for name in bundled_names("machines"):
        for use_dot in (False, True):
            bounds = bundled_graph(name, use_dot).bounds
            share = machine_share(bounds)
            for window in WINDOWS:
                zoom = graph_zoom(bounds, share, window)
                assert zoom >= LEGIBLE_ZOOM, (name, use_dot, window, zoom)
    # the rule itself: a graph too tall for the panel is shown below zoom 1, never below the
    # floor for these bounds, and the column never takes more than its share
    assert graph_zoom((0, 0, 400, 3000), 0.3, (1600, 900)) < LEGIBLE_ZOOM
    assert machine_share(None) == 0.24 and machine_share((0, 0, 5000, 500)) == 0.52


# -- peaks between control ticks --------------------------------------------------------------
PUSH = "push:object=cube,force_n=[0,0,-60],duration_ms=4@PICK.GRASP.VERIFY+0.043"
"""A 4 ms push on the held cube, starting between two control ticks (at 1.624 s, seed 0): the
hand feels ~50 N for two physics steps and is back under ~3 N by the next tick, under the
60 N contact-force limit."""


def test_a_force_spike_between_two_ticks_is_in_the_recording(tmp_path):
    loaded = load_scenario("pick_place", faults=[PUSH])
    # the 4 ms push jolts joint 2 just past its datasheet acceleration (7.86 rad/s^2 on 7.5):
    # `joint_acceleration` would abort; what is recorded here is the force spike
    guards = {k: v for k, v in loaded.scenario.guards.items() if k != "joint_acceleration"}
    loaded = replace(loaded, scenario=loaded.scenario.model_copy(update={"guards": guards}))
    rec = record(loaded, 0, tmp_path / "spike.rrd")
    assert rec.result.outcome == "succeeded"  # under the 60 N guard: nothing fires
    t_push = rec.result.metrics["faults"][0]["t"]
    rows = rec.temporal["/signals/wrist_force_n"]
    sampled = np.array([r["Scalars:scalars"][0] for r in rows])  # |F| at each tick
    peak = np.array([r["Scalars:scalars"][1] for r in rows])  # max over the tick's steps
    i = int(np.argmax(peak))
    assert t_push < rows[i]["sim_time"].total_seconds() <= t_push + 0.01  # the next tick
    # the spike fell between the ticks: the samples around it never saw it
    assert peak[i] > 40.0 and max(sampled[i - 2 : i + 3]) < 10.0
    assert peak[i] == pytest.approx(rec.result.metrics["max_wrist_force_n"], abs=1e-4)
    # the force guards read every physics step: their margin keeps the sensed spike
    # (rows without a sample are the clears that break the line where the guard is inactive)
    guard = [r for r in rec.temporal["/guards/contact_force"] if "Scalars:scalars" in r]
    margin = np.array([r["Scalars:scalars"][0] for r in guard])
    at = [r["tick"] for r in guard].index(rows[i]["tick"])
    assert margin[at] > 0.6 and max(*margin[at - 3 : at], *margin[at + 1 : at + 4]) < 0.2
    raw = np.array(rec.column("/guard_values/contact_force", "Scalars:scalars"))
    assert raw[at, 0] == pytest.approx(60.0 * margin[at])


@pytest.mark.slow
def test_recording_does_not_change_the_run(tmp_path):
    # the force sensor's noise is drawn at each instant the force is read: a recorder that
    # read it at a tick no guard read it at moved surgical_complication's abort (5.24 -> 5.22 N)
    loaded = load_scenario("surgical_complication")
    plain = run_episode(loaded, 0).to_json_dict()
    recorded = record(loaded, 0, tmp_path / "sc.rrd").result.to_json_dict()
    for result in (plain, recorded):
        result.pop("wall_time")
    assert recorded == plain
    assert recorded["reason"]["guard"] == "contact_force"


# -- the pictures in docs/ --------------------------------------------------------------------
_DOCS = Path(__file__).resolve().parents[1] / "docs"
PICTURE_PAGES = {
    "rerun_pick_place": ["recording.md", "../README.md"],
    "rerun_pick_place_vision": ["recording.md", "perception.md"],
    "rerun_mobile_search": ["recording.md", "mobile.md"],
    "rerun_sorting": ["recording.md", "sorting.md"],
    "rerun_sorting_conveyor": ["recording.md", "sorting.md"],
    "rerun_surgical": ["recording.md", "surgical.md"],
    "rerun_surgical_complication": ["recording.md", "surgical.md", "safety.md"],
    "rerun_stack": ["recording.md", "success-checks.md"],
    "rerun_reach_random": ["recording.md"],
    "machine_pick_place": ["recording.md", "machine-language.md", "../README.md"],
    "machine_surgical": ["recording.md", "machine-language.md", "surgical.md"],
    "live_spawn_pick_place": ["recording.md", "live.md"],
    "live_connect_pick_place": ["recording.md", "live.md"],
    **{
        f"rerun_{name}_1280x720": ["recording.md"]
        for name in (
            "pick_place",
            "pick_place_vision",
            "sorting",
            "sorting_conveyor",
            "mobile_search",
            "surgical",
            "surgical_complication",
            "stack",
            "reach_random",
            "pick_place_ur5",
            "pick_place_so101",
            "sorting_ur5",
        )
    },  # fmt: skip
    **{f"rerun_{n}": ["recording.md"] for n in ("pick_place_ur5", "pick_place_so101")},
    "rerun_sorting_ur5": ["recording.md"],
}
"""Each picture in docs/images -> the pages it illustrates (in docs/)."""


def test_every_picture_is_linked_from_the_pages_it_illustrates():
    assert sorted(p.stem for p in (_DOCS / "images").glob("*.png")) == sorted(PICTURE_PAGES)
    for name, pages in PICTURE_PAGES.items():
        for page in pages:
            prefix = "docs/images/" if page.startswith("../") else "images/"
            assert f"{prefix}{name}.png" in (_DOCS / page).read_text(), (name, page)


def test_every_picture_a_page_links_exists():
    for page in [*_DOCS.glob("*.md"), _DOCS.parent / "README.md"]:
        for link in re.findall(
            r"\(((?:docs/)?images/[^)\s]+)\)|src=\"([^\"]+)\"", page.read_text()
        ):
            target = next(part for part in link if part)
            assert (page.parent / target).is_file(), (page.name, target)
