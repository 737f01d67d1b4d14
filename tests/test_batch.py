"""Batch evaluation: results as they finish, crash isolation, resume, determinism, summary."""

from __future__ import annotations

import io
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from rich.console import Console

from orchestrator.batch import BatchConfig, BatchError, run_batch
from orchestrator.batch.backends import LocalBackend
from orchestrator.batch.progress import RichProgress
from orchestrator.batch.stats import percentile, wilson_interval
from orchestrator.batch.store import ResultsStore
from orchestrator.batch.summary import rerun_command, summarize
from orchestrator.batch.task import EpisodeTask

from .cli_runner import invoke
from .conftest import RESULT_KEYS

FAIL_GRASP = "grasp_offset=[0.0, 0.0, 0.06]"  # closes above the cube: a clean miss
"""Every grasp closes on air beside the cube: the episode fails (quickly) after retries."""


def _lines(path: Path) -> list[dict[str, Any]]:
    return [json.loads(t) for t in path.read_text().splitlines()]


def _by_seed(path: Path) -> dict[int, dict[str, Any]]:
    out = {}
    for line in _lines(path):
        line.pop("wall_time", None)
        line.pop("worker", None)  # which process ran it, and its memory: not the episode
        out[line["seed"]] = line
    return out


# -- statistics ---------------------------------------------------------------------------
def test_wilson_interval_matches_published_values():
    lo, hi = wilson_interval(5, 10)
    assert (round(lo, 4), round(hi, 4)) == (0.2366, 0.7634)
    lo, hi = wilson_interval(0, 10)
    assert lo == 0.0 and round(hi, 4) == 0.2775
    lo, hi = wilson_interval(10, 10)
    assert round(lo, 4) == 0.7225 and hi == 1.0
    assert wilson_interval(0, 0) == (0.0, 1.0)
    with pytest.raises(ValueError, match="successes must be in"):
        wilson_interval(11, 10)


def test_percentile_interpolates_like_numpy():
    xs = [3.9, 3.1, 4.4, 3.6, 5.0, 3.2, 3.3]
    for q in (0, 10, 50, 90, 99, 100):
        assert percentile(xs, q) == pytest.approx(float(np.percentile(xs, q)))
    with pytest.raises(ValueError, match="empty"):
        percentile([], 50)


# -- the results file ---------------------------------------------------------------------
def test_store_appends_whole_lines_and_cuts_a_torn_last_line(tmp_path):
    store = ResultsStore(tmp_path)
    store.open()
    store.append({"seed": 1, "outcome": "succeeded"})
    store.append({"seed": 2, "outcome": "failed"})
    store.close()
    with store.path.open("ab") as f:  # a SIGKILL in the middle of a write
        f.write(b'{"seed": 3, "outc')
    assert set(store.load()) == {1, 2}
    assert store.path.read_bytes().endswith(b"outc")  # load() alone changes nothing
    assert set(store.load(repair=True)) == {1, 2}
    assert store.path.read_bytes().endswith(b"}\n")
    store.open()
    store.append({"seed": 3, "outcome": "succeeded"})
    store.close()
    assert [ln["seed"] for ln in _lines(store.path)] == [1, 2, 3]


def test_store_names_a_corrupt_line_in_the_middle(tmp_path):
    store = ResultsStore(tmp_path)
    store.path.write_text('{"seed": 1}\nnot json\n{"seed": 2}\n')
    with pytest.raises(BatchError, match=r"results.jsonl:2: not a result line"):
        store.load()


# -- the summary --------------------------------------------------------------------------
def _line(seed: int, outcome: str, cycle: float | None = 3.0, guard: str | None = None):
    return {
        "seed": seed,
        "outcome": outcome,
        "metrics": {"cycle_time": cycle},
        "reason": {"guard": guard} if guard else None,
    }


def test_summary_counts_rates_abort_reasons_and_failing_seeds(tmp_path):
    lines = [_line(s, "succeeded", 3.0 + s / 10) for s in range(6)]
    lines += [
        _line(9, "aborted", None, "workspace"),
        _line(7, "failed", 4.0),
        _line(8, "aborted", None, "contact_force"),
        _line(6, "aborted", None, "workspace"),
        {"seed": 10, "outcome": "error", "error": {"type": "ValueError"}},
    ]
    s = summarize(
        lines,
        scenario="pick_place",
        scenario_ref="/x/my scenario.yaml",
        overrides=["place_at=[0.5, 0.2, 0.2]"],
        seed_base=0,
        backend="local",
        workers=2,
        wall_time_s=2.0,
        episodes_run=8,
        results=tmp_path / "results.jsonl",
        rrd_dir=tmp_path,
    )
    assert (s.episodes, s.succeeded, s.failed, s.aborted, s.errors) == (11, 6, 1, 3, 1)
    assert s.success_rate == pytest.approx(6 / 11, abs=1e-6)
    lo, hi = s.success_rate_ci95
    assert lo == pytest.approx(wilson_interval(6, 11)[0], abs=1e-6) and hi > s.success_rate
    assert s.abort_reasons == {"contact_force": 1, "workspace": 2}
    assert s.cycle_time_s is not None
    assert (s.cycle_time_s.min, s.cycle_time_s.max, s.cycle_time_s.p50) == (3.0, 3.5, 3.25)
    assert s.failing_seeds == [6, 7, 8, 9, 10]
    assert s.episodes_per_s == 4.0
    assert s.rerun_command == (
        "orchestrator run '/x/my scenario.yaml' --seed 6 --set 'place_at=[0.5, 0.2, 0.2]' "
        f"--rrd {tmp_path}/episodes/seed_6.rerun.rrd"
    )


def test_rerun_command_without_recording_has_no_rrd():
    assert rerun_command("pick_place", [], 4) == "orchestrator run pick_place --seed 4"


def test_progress_bar_shows_done_total_and_live_success_rate():
    buf = io.StringIO()
    bar = RichProgress(Console(file=buf, force_terminal=True, width=120), label="pick_place")
    bar.start(4, [_line(0, "succeeded")])
    bar.advance(_line(1, "failed"))
    bar.progress.refresh()
    bar.stop()
    text = buf.getvalue()
    assert "pick_place" in text and "2/4" in text
    assert "50.0%" in text and "1 not ok" in text


# -- the command line ---------------------------------------------------------------------
@pytest.fixture(scope="module")
def cli_batch(tmp_path_factory) -> tuple[Any, Path]:
    """`batch` from the command line: seeds 20-22 on 2 workers, recording as by default (the
    failures: none here), its result and its folder (also the 2-worker side of the determinism
    check below: a batch starts its own worker processes)."""
    out = tmp_path_factory.mktemp("cli_batch") / "b"
    args = ["batch", "pick_place", "-n", str(SEEDS), "--seed-base", "20", "--workers", "2",
            "--out", str(out), "--json"]  # fmt: skip
    return invoke(args), out


def test_batch_writes_a_line_per_episode_and_a_summary(cli_batch):
    res, out = cli_batch
    assert res.exit_code == 0, res.stderr
    assert res.exception is None or isinstance(res.exception, SystemExit), res.exception
    summary = json.loads(res.stdout)
    assert summary == json.loads((out / "summary.json").read_text())
    assert summary["episodes"] == summary["succeeded"] == 3
    assert summary["success_rate"] == 1.0 and summary["success_rate_ci95"][1] == 1.0
    assert summary["failing_seeds"] == [] and summary["rerun_command"] is None
    assert summary["cycle_time_s"]["p50"] > 0 and summary["episodes_per_s"] > 0
    lines = _lines(out / "results.jsonl")
    assert sorted(ln["seed"] for ln in lines) == [20, 21, 22]
    for line in lines:
        assert tuple(line)[: len(RESULT_KEYS)] == RESULT_KEYS
        assert line["scenario"] == "pick_place" and line["outcome"] == "succeeded"
        assert line["worker"]["rss_mb"] > 50 and line["worker"]["episode"] >= 1
    # each worker's memory at its first and last episode, from those lines
    memory = summary["memory"]
    assert sum(w["episodes"] for w in memory["workers"]) == 3
    assert {w["pid"] for w in memory["workers"]} == {ln["worker"]["pid"] for ln in lines}
    for w in memory["workers"]:
        assert w["growth_mb"] == pytest.approx(w["rss_end_mb"] - w["rss_start_mb"], abs=0.11)


def test_failing_seeds_are_listed_with_the_command_that_reruns_one(cli, tmp_path):
    out = tmp_path / "b"
    res = cli(
        "batch",
        "pick_place",
        "-n",
        "2",
        "--workers",
        "2",
        "--out",
        str(out),
        "--set",
        FAIL_GRASP,
        "--record",
        "none",
    )
    assert res.exit_code == 0, res.stderr  # the batch ran; the task failing is a statistic
    assert "failing seeds: 0, 1" in res.stdout
    assert (
        "orchestrator run pick_place --seed 0 --set 'grasp_offset=[0.0, 0.0, 0.06]'" in res.stdout
    )
    summary = json.loads((out / "summary.json").read_text())
    assert summary["failed"] == 2 and summary["success_rate"] == 0.0
    # the printed command reproduces the episode
    again = cli("run", "pick_place", "--seed", "0", "--set", FAIL_GRASP, "--json")
    assert again.exit_code == 1
    first = _by_seed(out / "results.jsonl")[0]
    rerun = again.json
    rerun.pop("wall_time")
    assert rerun == first


def run_with_a_bug(task: EpisodeTask) -> dict[str, Any]:
    """A worker function: the real `run_task`, with an episode that raises on seed 1."""
    from orchestrator.batch import episode

    real = episode.drive  # what runs the episode's ticks
    if task.seed == 1:

        def broken(*args: Any, **kwargs: Any) -> Any:
            raise ZeroDivisionError("a bug deep inside an episode")

        episode.drive = broken  # type: ignore[assignment]
    try:
        return episode.run_task(task)
    finally:
        episode.drive = real  # type: ignore[assignment]


def test_an_exception_in_an_episode_is_recorded_and_the_batch_goes_on(cli, tmp_path, monkeypatch):
    out = tmp_path / "b"
    monkeypatch.setattr(
        "orchestrator.batch.run.make_backend", lambda *a: LocalBackend(1, run_fn=run_with_a_bug)
    )
    res = cli("batch", "pick_place", "-n", "3", "--out", str(out), "--record", "none", "--json")
    assert res.exit_code == 1, res.stderr  # some episode raised: not a clean batch
    summary = res.json
    lines = {ln["seed"]: ln for ln in _lines(out / "results.jsonl")}
    assert sorted(lines) == [0, 1, 2]  # the batch went on after seed 1, on the same worker
    assert lines[0]["outcome"] == lines[2]["outcome"] == "succeeded"
    error = lines[1]["error"]
    assert lines[1]["outcome"] == "error" and lines[1]["scenario"] == "pick_place"
    assert error["type"] == "ZeroDivisionError"
    assert error["message"] == "a bug deep inside an episode"
    assert "Traceback (most recent call last)" in error["traceback"]
    assert "raise ZeroDivisionError" in error["traceback"]
    assert (summary["errors"], summary["failing_seeds"]) == (1, [1])


def test_invalid_input_exits_2_before_anything_runs(cli, tmp_path):
    out = tmp_path / "b"
    res = cli("batch", "pick_place", "-n", "2", "--out", str(out), "--set", "no_such_key=1")
    assert res.exit_code == 2 and res.exception is None
    assert "<--set>" in res.stderr and "not a blackboard key" in res.stderr
    assert "Traceback" not in res.stderr + res.stdout
    assert not out.exists()
    res = cli("batch", "pick_place", "-n", "2", "--resume")
    assert res.exit_code == 2 and "--resume needs --out" in res.stderr
    res = cli("batch", "pick_place", "-n", "0", "--out", str(out))
    assert res.exit_code == 2
    res = cli("batch", "pick_place", "-n", "1", "--out", str(out), "--address", "10.0.0.1:6379")
    assert res.exit_code == 2 and "add --backend ray" in res.stderr
    assert not out.exists()


def test_an_existing_batch_is_never_overwritten_and_resumed_only_as_itself(cli, tmp_path):
    out = tmp_path / "b"
    (out).mkdir()
    store = ResultsStore(out)
    store.open()
    store.append({"seed": 0, "outcome": "succeeded", "scenario": "pick_place"})
    store.close()
    res = cli("batch", "pick_place", "-n", "2", "--out", str(out))
    assert res.exit_code == 2 and "pass --resume" in res.stderr
    (out / "batch.json").write_text(
        json.dumps({"scenario": "pick_place", "scenario_path": "/elsewhere.yaml", "overrides": []})
    )
    res = cli("batch", "pick_place", "-n", "2", "--out", str(out), "--resume")
    assert res.exit_code == 2 and "another scenario or other --set" in res.stderr
    assert len(_lines(out / "results.jsonl")) == 1


def test_ray_missing_is_a_clear_error(cli, tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "ray", None)  # `import ray` raises ImportError
    res = cli("batch", "pick_place", "-n", "1", "--backend", "ray", "--out", str(tmp_path / "b"))
    assert res.exit_code == 2 and res.exception is None
    assert "pip install 'embodied-orchestrator[ray]'" in res.stderr


# -- crash isolation: a worker process that dies -------------------------------------------
def crashing_run(task: EpisodeTask) -> dict[str, Any]:
    """A worker function: seed 1 always kills its process, seed 2 only on its first try."""
    marker = Path(task.out_dir or ".") / f"crashed_{task.seed}"
    if task.seed == 1 or (task.seed == 2 and not marker.exists()):
        marker.touch()
        os._exit(3)
    return {
        "scenario": "fake",
        "seed": task.seed,
        "outcome": "succeeded",
        "metrics": {"cycle_time": 1.0},
        "pid": os.getpid(),
    }


def test_a_dead_worker_is_replaced_and_its_episode_retried_once(tmp_path):
    config = BatchConfig("pick_place", 5, tmp_path / "b", record="none")
    backend = LocalBackend(2, run_fn=crashing_run)
    summary = run_batch(config, backend=backend)
    lines = {ln["seed"]: ln for ln in _lines(tmp_path / "b" / "results.jsonl")}
    assert sorted(lines) == [0, 1, 2, 3, 4]
    assert lines[2]["outcome"] == "succeeded"  # died once, retried on a fresh worker
    assert lines[1]["outcome"] == "error"
    assert lines[1]["error"]["type"] == "WorkerDied"
    assert (
        "exit code 3" in lines[1]["error"]["message"] and "2 times" in lines[1]["error"]["message"]
    )
    assert (summary.succeeded, summary.errors, summary.failing_seeds) == (4, 1, [1])


def environment_run(task: EpisodeTask) -> dict[str, Any]:
    """A worker function: reports the worker's $ORCHESTRATOR_TEST_MARK as its metric."""
    return {
        "scenario": "fake",
        "seed": task.seed,
        "outcome": "succeeded",
        "metrics": {"mark": float(os.environ.get("ORCHESTRATOR_TEST_MARK", "-1"))},
    }


def test_workers_see_the_parents_environment_of_now_not_the_fork_servers(tmp_path, monkeypatch):
    # the fork server is started once per process and keeps the environment of that moment:
    # a snapshot key changed since (as a test fixture or a library user does) must still reach
    # the workers, or their snapshots are signed with a key nobody else reads
    marks = []
    for mark in ("1", "2"):
        monkeypatch.setenv("ORCHESTRATOR_TEST_MARK", mark)
        config = BatchConfig("pick_place", 1, tmp_path / f"b{mark}", record="none")
        run_batch(config, backend=LocalBackend(1, run_fn=environment_run))
        (line,) = _lines(tmp_path / f"b{mark}" / "results.jsonl")
        marks.append(line["metrics"]["mark"])
    assert marks == [1.0, 2.0]


# -- resume after SIGKILL -----------------------------------------------------------------
@pytest.mark.slow  # a batch killed and resumed (~12 s)
def test_sigkill_then_resume_runs_every_seed_exactly_once(tmp_path, cli_process):
    out = tmp_path / "b"
    n = 6  # killed after 2 or 3 (an episode takes seconds): the resume runs the rest
    args = [
        "batch",
        "pick_place",
        "-n",
        str(n),
        "--workers",
        "2",
        "--out",
        str(out),
        "--record",
        "none",
        "--json",
    ]
    proc = subprocess.Popen(
        [sys.executable, "-m", "orchestrator.cli", *args],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        start_new_session=True,
    )
    results = out / "results.jsonl"
    deadline = time.monotonic() + 120
    try:
        while time.monotonic() < deadline:
            if results.is_file() and results.read_bytes().count(b"\n") >= 2:
                break
            assert proc.poll() is None, "the batch ended before it could be killed"
            time.sleep(0.02)
    finally:
        os.killpg(proc.pid, signal.SIGKILL)  # the parent, its fork server and its workers
        proc.wait()
    done = results.read_bytes().count(b"\n")
    assert 2 <= done < n
    with results.open("ab") as f:
        f.write(b'{"scenario": "pick_place", "seed": 9')  # as if killed mid-write
    res = cli_process(*args[:-1], "--resume", "--json")
    assert res.exit_code == 0, res.stderr
    seeds = [ln["seed"] for ln in _lines(results)]
    assert sorted(seeds) == list(range(n))  # every seed, exactly once
    summary = json.loads(res.stdout)
    assert summary["episodes"] == n and summary["episodes_run"] == n - done


# -- determinism across workers and backends ------------------------------------------------
SEEDS = 3


def _batch(tmp_path: Path, name: str, **kw: Any) -> dict[int, dict[str, Any]]:
    config = BatchConfig("pick_place", SEEDS, tmp_path / name, seed_base=20, record="none", **kw)
    run_batch(config)
    return _by_seed(tmp_path / name / "results.jsonl")


@pytest.fixture(scope="module")
def local_results(tmp_path_factory, cli_batch) -> dict[int, dict[int, dict[str, Any]]]:
    """Seeds 20-22 on one worker, and on two (the command line's batch above)."""
    tmp = tmp_path_factory.mktemp("determinism")
    return {1: _batch(tmp, "w1", workers=1), 2: _by_seed(cli_batch[1] / "results.jsonl")}


def test_results_do_not_depend_on_the_worker_count(local_results, pick_place):
    one, two = local_results[1], local_results[2]
    assert sorted(one) == [20, 21, 22]
    assert one == two
    # ... nor on running in a worker at all
    from orchestrator.engine.runner import run_episode

    direct = run_episode(pick_place, 21).to_json_dict()
    direct.pop("wall_time")
    assert one[21] == direct


@pytest.fixture(scope="module")
def local_ray():
    """A local Ray with 2 CPUs, shared by the Ray tests of this module."""
    ray = pytest.importorskip(
        "ray", reason="the Ray backend is an optional extra: pip install -e '.[ray]'"
    )
    here = Path(__file__).resolve().parent  # Ray workers import this module's run functions
    ray.init(
        num_cpus=2,
        include_dashboard=False,
        logging_level="WARNING",
        log_to_driver=False,
        runtime_env={"env_vars": {"PYTHONPATH": os.pathsep.join([str(here.parent), str(here)])}},
    )
    yield ray
    ray.shutdown()


@pytest.mark.slow  # a local Ray cluster: ~1 min to start and run
def test_results_do_not_depend_on_the_backend(local_results, local_ray, tmp_path):
    on_ray = _batch(tmp_path, "ray", backend="ray", workers=2)
    assert on_ray == local_results[1]


@pytest.mark.slow  # a local Ray cluster
def test_a_dead_ray_worker_is_retried_once_then_an_error(local_ray, tmp_path):
    from orchestrator.batch.backends.ray import RayBackend

    config = BatchConfig("pick_place", 4, tmp_path / "b", record="none")
    summary = run_batch(config, backend=RayBackend(2, run_fn=crashing_run))
    lines = {ln["seed"]: ln for ln in _lines(tmp_path / "b" / "results.jsonl")}
    assert sorted(lines) == [0, 1, 2, 3]
    assert lines[2]["outcome"] == "succeeded"  # Ray re-ran it once
    assert lines[1]["outcome"] == "error" and lines[1]["error"]["type"] == "WorkerCrashedError"
    assert (summary.succeeded, summary.errors) == (3, 1)


@pytest.mark.slow  # a local Ray cluster
def test_a_ray_worker_that_cannot_import_the_package_is_one_clear_error(local_ray, tmp_path):
    # a node started by another Python than the package's: every episode used to end `error`
    # with "No module named 'orchestrator.robots'"
    from orchestrator.batch.backends.ray import RayBackend

    backend = RayBackend(2)
    backend.probe = ("orchestrator.robots", "orchestrator.not_installed_on_that_node")
    config = BatchConfig("pick_place", 2, tmp_path / "b", record="none")
    with pytest.raises(BatchError, match="cannot run an episode .*not_installed_on_that_node"):
        run_batch(config, backend=backend)
    assert local_ray.is_initialized()  # the cluster it joined is left running


# -- recording ----------------------------------------------------------------------------
@pytest.fixture
def recording():
    try:
        from orchestrator.recording import RerunRecorder  # noqa: F401
    except ImportError as exc:
        pytest.skip(f"orchestrator.recording is not available yet: {exc}")


def test_failures_are_recorded_and_successes_are_not(recording, cli, tmp_path, cli_batch):
    out = tmp_path / "fail"
    res = cli(
        "batch",
        "pick_place",
        "-n",
        "1",
        "--workers",
        "1",
        "--out",
        str(out),
        "--json",
        "--set",
        FAIL_GRASP,
    )
    assert res.exit_code == 0, res.stderr
    line = _lines(out / "results.jsonl")[0]
    assert line["rrd"] == "episodes/seed_0.rrd" and "rrd_error" not in line
    assert (out / "episodes" / "seed_0.rrd").stat().st_size > 0
    assert res.json["rerun_command"].endswith(
        f"--rrd {out}/episodes/seed_0.rerun.rrd"
    )  # never over the saved one
    res, out = cli_batch  # 3 successes, recorded as by default
    assert res.exit_code == 0, res.stderr
    lines = _lines(out / "results.jsonl")
    assert len(lines) == 3 and all(ln["outcome"] == "succeeded" for ln in lines)
    assert not any("rrd" in ln for ln in lines)
    assert not (out / "episodes").exists()
    out = tmp_path / "all"
    res = cli(
        "batch",
        "pick_place",
        "-n",
        "1",
        "--workers",
        "1",
        "--out",
        str(out),
        "--json",
        "--record",
        "all",
    )
    assert res.exit_code == 0, res.stderr
    assert (out / "episodes" / "seed_0.rrd").stat().st_size > 0
