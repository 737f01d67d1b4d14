"""Rerun recording: what an episode's .rrd holds, read back with `rerun.chunk.RrdReader`."""

from __future__ import annotations

import socket
from collections import defaultdict
from dataclasses import dataclass
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
from orchestrator.language.load import LoadedScenario, load_scenario
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
from orchestrator.recording.machine_graph import KIND_COLORS
from orchestrator.recording.state_log import StateLog
from orchestrator.recording.static_scene import static_scene
from orchestrator.recording.timeline import Rows, seconds_to_ns
from orchestrator.recording.viewer import spawn_viewer
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
    static: dict[str, dict] = defaultdict(dict)
    for chunk in RrdReader(path).stream().to_chunks():
        for raw in chunk.to_record_batch().to_pylist():
            row_id = raw.pop(ROW_ID)
            row = {k: v for k, v in raw.items() if v is not None}
            if chunk.is_static:
                static[chunk.entity_path].update(row)
            else:
                temporal[chunk.entity_path].append((row_id, row))
    ordered = {e: [r for _, r in sorted(rows, key=lambda x: x[0])] for e, rows in temporal.items()}
    return ordered, dict(static)


def record(loaded: LoadedScenario, seed: int, path: Path, **kwargs: Any) -> Recording:
    recorder = RerunRecorder(path=path, **kwargs)
    result = run_episode(loaded, seed, [recorder])
    assert recorder.rec is None, "on_end closes the stream: the file is complete"
    temporal, static = read_rrd(path)
    return Recording(path, result, temporal, static)


@pytest.fixture(scope="module")
def recorded(pick_place, tmp_path_factory) -> Recording:
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
    assert ticks == list(range(recorded.result.metrics["control_ticks"] + 1))
    xyz = np.array([r["Transform3D:translation"][0] for r in hand])
    assert np.ptp(xyz, axis=0).max() > 0.1  # the hand travels tens of centimetres
    cube = np.array(recorded.column("/world/bodies/cube", "Transform3D:translation"))[:, 0]
    assert not np.allclose(cube[0], cube[-1], atol=0.05)  # the cube was carried to the pad


def test_a_guard_violation_is_an_error_with_the_guards_name(aborted):
    assert aborted.result.outcome == "aborted"
    assert aborted.result.reason["guard"] == "workspace"
    rows = aborted.temporal["/events/violation"]
    assert [r["TextLog:level"] for r in rows] == [["ERROR"]]
    text = rows[0]["TextLog:text"][0]
    assert "workspace" in text
    assert "value" in text and "limit" in text
    assert str(aborted.result.reason["limit"]["bound"]) in text
    # the abort is a state change like any other, into the built-in safe stop
    states = [s[0] for s in aborted.column("/state_machine/active", "StateChange:state")]
    assert states[-1] == SAFE_STOP == aborted.result.transitions[-1]["to"]


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
    assert {len(f) for f in force} == {4} and {len(t) for t in torque} == {7}
    f = np.array(force)
    assert np.allclose(f[:, 3], np.linalg.norm(f[:, :3], axis=1))
    assert max(f[:, 3]) == pytest.approx(recorded.result.metrics["max_wrist_force_n"], abs=1e-4)
    width = np.array(recorded.column("/signals/gripper_width_m", "Scalars:scalars"))[:, 0]
    assert width.max() > 0.07 and width.min() < 0.06  # open, then closed on the 5 cm cube
    error = np.array(recorded.column("/signals/tcp_error_m", "Scalars:scalars"))[:, 0]
    assert 0 < len(error) < n and error.min() < 0.005 < error.max()
    names = recorded.static["/signals/joint_torque_nm"]["SeriesLines:names"]
    assert names == [f"panda_joint{i}" for i in range(1, 8)]


def test_each_guard_is_plotted_next_to_its_limit(recorded):
    force = recorded.column("/guards/contact_force", "Scalars:scalars")
    assert force and {row[1] for row in force} == {60.0}  # the scenario's max_n
    for guard in ("workspace", "joint_limits"):
        margins = np.array(recorded.column(f"/guards/{guard}", "Scalars:scalars"))
        assert (margins[:, 0] > margins[:, 1]).all(), guard  # safe run: inside the limits


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


def test_graph_lights_the_active_state_at_every_transition(recorded, pick_place):
    graph = recorded.static["/state_machine/graph"]
    nodes = graph["GraphNodes:node_ids"]
    assert set(nodes) == {p for p, _, _ in pick_place.machine.walk()} | {SAFE_STOP}
    rows = recorded.temporal["/state_machine/graph"]
    assert len(rows) == len(recorded.result.transitions) + 1
    last = rows[-1]["GraphNodes:radii"]
    lit = [n for n, r in zip(nodes, last, strict=True) if r > 10]
    assert lit == ["DONE"]


def test_nested_levels_have_their_own_lanes(recorded):
    root = [s[0] for s in recorded.column("/state_machine/levels/root", "StateChange:state")]
    pick = [s[0] for s in recorded.column("/state_machine/levels/PICK", "StateChange:state")]
    assert root[0] == "PICK" and root[-1] == "DONE"
    assert pick[0] == "SEARCH" and pick[-1] == ""  # reset when PICK is left


def test_the_recording_opens_with_the_default_blueprint(recorded):
    reader = RrdReader(recorded.path)
    assert len(reader.recordings()) == 1
    assert len(reader.blueprints()) == 1


@pytest.mark.parametrize("name", bundled_names("scenarios"))
def test_every_bundled_scenario_records_its_transitions_and_geoms(name, tmp_path):
    loaded = load_scenario(name)
    rec = record(loaded, 0, tmp_path / f"{name}.rrd")
    states = [s[0] for s in rec.column("/state_machine/active", "StateChange:state")]
    transitions = rec.result.transitions
    assert states == [transitions[0]["from"]] + [t["to"] for t in transitions]
    model = World.build(loaded.scenario, 0).model
    drawn = [e for e in rec.static if "/geoms/" in e]
    assert len(drawn) == len(visible_geoms(model))


def test_cli_rrd_writes_a_recording(cli, tmp_path):
    path = tmp_path / "nested" / "run.rrd"
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
    assert ("TRANSPORT", SAFE_STOP) in graph.edges  # abort from a top-level state
    assert set(graph.positions) == set(graph.states)


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
    assert ("A", "HALT") in graph.edges


def test_lanes_reset_when_their_owner_is_left(pick_place):
    log = StateLog(build_graph(pick_place.machine))
    log.enter(0, 0.0, "PICK.SEARCH")
    log.enter(1, 0.01, "TRANSPORT")
    assert log._lanes["PICK"] == [(0, 0.0, "SEARCH"), (1, 0.01, "")]
    assert log._lanes[""] == [(0, 0.0, "PICK"), (1, 0.01, "TRANSPORT")]


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
    with pytest.raises(RecordingError, match="path=<file.rrd> or spawn=True"):
        RerunRecorder()
    with pytest.raises(RecordingError, match="flush_every_ticks"):
        RerunRecorder(path="x.rrd", flush_every_ticks=0)


def test_flushing_in_batches_records_the_same_rows(pick_place, recorded, tmp_path):
    batched = record(pick_place, 0, tmp_path / "batched.rrd", flush_every_ticks=7)

    def canonical(temporal: dict[str, list[dict]]) -> dict[str, list[dict]]:
        # batches interleave an entity's separately sent components differently; the rows
        # of one component keep their order (stable sort)
        return {e: sorted(rs, key=lambda r: (r["tick"], sorted(r))) for e, rs in temporal.items()}

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
