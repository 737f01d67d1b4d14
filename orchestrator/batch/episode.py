"""The worker side: run one episode, never raise, return its results.jsonl line.

Workers import this module once (the local backend preloads it in its fork server) and load
each scenario once per process from (reference, overrides), then reuse it for every seed.
"""

from __future__ import annotations

import traceback
from pathlib import Path
from typing import Any

from ..engine.result import RunResult
from ..engine.runner import Observer, WallTimeExceeded, drive, new_run, run_episode
from ..engine.snapshot import EntryLog, last_entry_stop, local_skill_files, run_to, write_run
from ..engine.snapshot.breaks import final_paths
from ..language.load import LoadedScenario, load_scenario
from ..language.scenario_skills import register_user_skills
from .memory import release_episode, rss_mb, worker_stamp
from .task import EpisodeTask, error_line, rrd_name, snapshot_name

__all__ = ["loaded_scenario", "run_task", "same_episode"]

_LOADED: dict[tuple[str, tuple[str, ...], tuple[str, ...]], LoadedScenario] = {}


def loaded_scenario(
    ref: str,
    overrides: tuple[str, ...],
    allow_paths: tuple[str, ...] = (),
    skill_paths: tuple[str, ...] = (),
) -> LoadedScenario:
    """The scenario `ref` with `overrides`, loaded once per process (after registering the
    batch's `--skills` paths: a worker forked before them, or a Ray worker, has not)."""
    key = (ref, overrides, allow_paths)
    register_user_skills(skill_paths)
    if key not in _LOADED:
        _LOADED[key] = load_scenario(ref, list(overrides), allow_paths=allow_paths)
    return _LOADED[key]


_NOT_THE_EPISODE = ("wall_time", "worker")
"""Result-line keys that describe how an episode ran (wall time, the worker's memory), not
what happened in it."""


def same_episode(a: dict[str, Any], b: dict[str, Any]) -> bool:
    """Two result lines describe the same episode: equal in everything but wall time and
    the worker that ran it."""
    return {k: v for k, v in a.items() if k not in _NOT_THE_EPISODE} == {
        k: v for k, v in b.items() if k not in _NOT_THE_EPISODE
    }


def run_task(task: EpisodeTask) -> dict[str, Any]:
    """Run `task` and return its line: the RunResult's JSON (which includes `seed`), plus
    `rrd` when a recording was saved, and `worker` (the process and its RSS before and after
    the episode, batch/memory.py); outcome `error` with the traceback if anything raised.
    What the episode held is freed before its RSS is read (`release_episode`).
    """
    before = rss_mb()
    line = _run(task)
    release_episode()  # the episode's native memory, held in reference cycles
    line["worker"] = worker_stamp(before)
    return line


def _run(task: EpisodeTask) -> dict[str, Any]:
    log: EntryLog | None = None
    try:
        loaded = loaded_scenario(task.scenario, task.overrides, task.allow_paths, task.skill_paths)
        run = new_run(loaded, task.seed)
        if task.snapshot_on_failure:  # where each state was entered, to break there later
            log = EntryLog(run)
            run.executor.entry_listeners.append(log)
        observers = [_recorder(task)] if task.record == "all" else []
        result = drive(run, observers, task.max_wall_s)
        assert result is not None
        line = result.to_json_dict()
        if task.record == "all":
            line["rrd"] = rrd_name(task.seed)
    except WallTimeExceeded as exc:  # the episode was stopped: its reason, not a traceback
        return error_line(task, type(exc).__name__, str(exc), None)
    except Exception as exc:  # crash isolation: whatever went wrong is this episode's error
        return error_line(task, type(exc).__name__, _one_line(exc), traceback.format_exc())
    if task.record == "failures" and result.outcome != "succeeded":
        line.update(_record_again(loaded, task, result))
    if log is not None and result.outcome != "succeeded":
        line.update(_snapshot_again(loaded, task, log))
    return line


def _snapshot_again(loaded: LoadedScenario, task: EpisodeTask, log: EntryLog) -> dict[str, Any]:
    """Run a failed episode again to the start of the tick of its last state entry before the
    failure and keep that snapshot (`snapshots/seed_<S>.snap`, or `snapshot_error`: why not)."""
    try:
        stop = last_entry_stop(log, final_paths(loaded.machine).__contains__)
        if stop is None:
            return {"snapshot_error": "no state was entered before the failure"}
        run = new_run(loaded, task.seed)
        if not run_to(run, stop):
            return {"snapshot_error": "the re-run ended before that tick (not deterministic)"}
        assert task.out_dir is not None
        write_run(Path(task.out_dir) / snapshot_name(task.seed), run, stop.header(),
                  local_skill_files())  # fmt: skip
    except Exception as exc:  # the episode's result stands; say why there is no snapshot
        return {"snapshot_error": f"{type(exc).__name__}: {_one_line(exc)}"}
    return {"snapshot": snapshot_name(task.seed), "snapshot_state": stop.reason}


def _record_again(loaded: LoadedScenario, task: EpisodeTask, result: RunResult) -> dict[str, Any]:
    """Re-run a failed episode with a recorder; episodes are deterministic, so it is the same."""
    try:
        again = run_episode(loaded, task.seed, [_recorder(task)], task.max_wall_s)
    except Exception as exc:  # the episode's result stands; say why there is no recording
        return {"rrd_error": f"{type(exc).__name__}: {_one_line(exc)}"}
    extra: dict[str, Any] = {"rrd": rrd_name(task.seed)}
    if not same_episode(again.to_json_dict(), result.to_json_dict()):
        extra["rrd_error"] = "the recorded re-run differed from the episode (not deterministic)"
    return extra


def _recorder(task: EpisodeTask) -> Observer:
    from ..recording import RerunRecorder  # type: ignore[import-not-found]

    path = task.rrd_path()
    path.parent.mkdir(parents=True, exist_ok=True)
    recorder: Observer = RerunRecorder(path=path, spawn=False)
    return recorder


def _one_line(exc: BaseException) -> str:
    text = str(exc).strip()
    return text.splitlines()[0] if text else type(exc).__name__
