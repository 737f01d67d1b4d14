"""The worker side: run one episode, never raise, return its results.jsonl line.

Workers import this module once (the local backend preloads it in its fork server) and load
each scenario once per process from (reference, overrides), then prepare each seed from it
as `orchestrator run` does (engine/prepare.py: its world compiled once, its goals checked).
"""

from __future__ import annotations

import errno
import traceback
from pathlib import Path
from typing import Any

from ..engine.prepare import Prepared, prepare
from ..engine.result import RunResult
from ..engine.runner import Observer, WallTimeExceeded, drive
from ..engine.snapshot import EntryLog, last_entry_stop, local_skill_files, run_to, write_run
from ..engine.snapshot.breaks import final_paths
from ..exceptions import ConfigError
from ..language.scenario_skills import register_user_skills
from .memory import release_episode, rss_mb, worker_stamp
from .task import NOT_WRITTEN, EpisodeTask, error_line, rrd_name, snapshot_name

__all__ = ["forget_prepared", "prepared_episode", "run_task", "same_episode"]

_PREPARED: dict[tuple[str, tuple[str, ...], tuple[str, ...]], Prepared] = {}


def prepared_episode(task: EpisodeTask) -> Prepared:
    """The episode of `task`, prepared as `orchestrator run` prepares it (engine/prepare.py):
    the scenario with the batch's overrides is loaded once per process, then each seed gets
    its world compiled and its goals checked on it.

    Raises:
        ConfigError: What `run --seed SEED` with the batch's `--set` would refuse.
    """
    key = (task.scenario, task.overrides, task.allow_paths)
    register_user_skills(task.skill_paths)  # a worker forked before them, or a Ray worker
    if key not in _PREPARED:
        _PREPARED[key] = prepare(
            task.scenario, task.seed, task.overrides, allow_paths=task.allow_paths
        )
    return _PREPARED[key].reseeded(task.seed)


def forget_prepared(task: EpisodeTask) -> None:
    """Drop what `prepared_episode` keeps for `task`'s scenario and overrides: an exploration
    runs each set of overrides once or a few times, and a worker must not keep them all."""
    _PREPARED.pop((task.scenario, task.overrides, task.allow_paths), None)


_DISK_FULL = (errno.ENOSPC, errno.EDQUOT, errno.EFBIG)
"""A write that failed for want of room: the machine's trouble, not the episode's."""

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
        prepared = prepared_episode(task)
        run = prepared.new_run()
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
    except ConfigError as exc:  # refused as `run` refuses it (a goal by the objects drawn)
        return error_line(task, type(exc).__name__, _one_line(exc), None)
    except OSError as exc:
        if exc.errno not in _DISK_FULL:
            return error_line(task, type(exc).__name__, _one_line(exc), traceback.format_exc())
        return {"seed": task.seed, NOT_WRITTEN: exc.strerror or str(exc)}  # no result: retried
    except Exception as exc:  # crash isolation: whatever went wrong is this episode's error
        return error_line(task, type(exc).__name__, _one_line(exc), traceback.format_exc())
    if task.record == "failures" and result.outcome != "succeeded":
        line.update(_record_again(prepared, task, result))
    if log is not None and result.outcome != "succeeded":
        line.update(_snapshot_again(prepared, task, log))
    return line


def _snapshot_again(prepared: Prepared, task: EpisodeTask, log: EntryLog) -> dict[str, Any]:
    """Run a failed episode again to the start of the tick of its last state entry before the
    failure and keep that snapshot (`snapshots/seed_<S>.snap`, or `snapshot_error`: why not)."""
    try:
        stop = last_entry_stop(log, final_paths(prepared.loaded.machine).__contains__)
        if stop is None:
            return {"snapshot_error": "no state was entered before the failure"}
        run = prepared.new_run()
        if not run_to(run, stop):
            return {"snapshot_error": "the re-run ended before that tick (not deterministic)"}
        assert task.out_dir is not None
        write_run(Path(task.out_dir) / snapshot_name(task.seed), run, stop.header(),
                  local_skill_files())  # fmt: skip
    except Exception as exc:  # the episode's result stands; say why there is no snapshot
        return {"snapshot_error": f"{type(exc).__name__}: {_one_line(exc)}"}
    return {"snapshot": snapshot_name(task.seed), "snapshot_state": stop.reason}


def _record_again(prepared: Prepared, task: EpisodeTask, result: RunResult) -> dict[str, Any]:
    """Re-run a failed episode with a recorder; episodes are deterministic, so it is the same."""
    try:
        again = prepared.run_episode([_recorder(task)], task.max_wall_s)
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
