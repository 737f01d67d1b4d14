"""`run_batch`: validate once, run the missing seeds on a backend, write results and summary."""

from __future__ import annotations

import json
import os
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from ..engine.prepare import prepare
from ..engine.strict_json import dumps
from .backends import Backend, make_backend
from .config import BatchConfig, RecordMode, portable_ref
from .exceptions import BatchError
from .lock import BatchLock
from .progress import BatchProgress, NullProgress
from .store import ResultsStore
from .summary import SUMMARY, BatchSummary, summarize
from .task import NOT_WRITTEN, EpisodeTask

__all__ = ["MANIFEST", "recording_unavailable", "run_batch"]

MANIFEST = "batch.json"
"""What a batch directory holds results of: a resumed batch must run the same scenario."""


def recording_unavailable() -> str | None:
    """None when `orchestrator.recording` can be imported, else why not."""
    try:
        from ..recording import RerunRecorder  # type: ignore[import-not-found]  # noqa: F401
    except ImportError as exc:
        return str(exc) or type(exc).__name__
    return None


def run_batch(
    config: BatchConfig,
    progress: BatchProgress | None = None,
    backend: Backend | None = None,
    warn: Callable[[str], None] | None = None,
) -> BatchSummary:
    """Run a batch; every check happens before anything is written or started.

    Args:
        config: What to run.
        progress: Told about each finished episode (default: nothing shown).
        backend: Where to run (default: the one `config` names).
        warn: Receives warnings, e.g. that recording is unavailable.

    Returns:
        The summary, also written to `config.out_dir/summary.json`.

    Raises:
        ConfigError: The scenario or an override is invalid (nothing was run).
        BatchError: The batch directory or backend cannot be used as asked.
    """
    progress = progress or NullProgress()
    if config.seed_base < 0:
        raise BatchError(
            f"--seed-base must be >= 0 (seeds are non-negative), got {config.seed_base}"
        )
    if config.address and config.backend != "ray":
        raise BatchError(f"--address {config.address} is a Ray cluster: add --backend ray")
    allow = tuple(str(Path(a).resolve()) for a in config.allow_paths)
    # the front door `run` goes through, for the first seed: what `run` refuses is refused
    # here, with the same message, before anything runs (each episode goes through it again)
    loaded = prepare(config.scenario, config.seed_base, config.overrides, allow_paths=allow).loaded
    ref = portable_ref(config.scenario)
    no_recording = recording_unavailable()
    record = _record_mode(config.record, no_recording, warn)
    out_dir = config.out_dir.resolve()
    store = ResultsStore(out_dir)
    manifest = {
        "scenario": loaded.name,
        "scenario_path": str(loaded.path.resolve()),
        "overrides": list(config.overrides),
    }
    with BatchLock(out_dir):  # one batch per directory: a second one exits naming this one
        existing = _check_out_dir(out_dir, store, manifest, config.resume)
        if backend is None:
            backend = make_backend(config.backend, config.workers, config.address)

        seeds = set(config.seeds)
        finished = [line for seed, line in sorted(existing.items()) if seed in seeds]
        todo = [s for s in config.seeds if s not in existing]
        tasks = [
            EpisodeTask(
                ref,
                config.overrides,
                s,
                record,
                str(out_dir),
                config.max_wall_s,
                allow,
                config.snapshot_on_failure,
                config.skill_paths,
            )
            for s in todo
        ]
        new: list[dict[str, Any]] = []
        t0 = time.perf_counter()
        try:
            out_dir.mkdir(parents=True, exist_ok=True)
            _write_json(out_dir / MANIFEST, manifest)
            store.open()
        except OSError as exc:
            raise _write_failed(out_dir, exc, 0) from None
        progress.start(len(seeds), finished)
        try:
            if tasks:
                for line in backend.run(tasks):
                    not_written = line.get(NOT_WRITTEN)
                    if not_written:  # the worker could not write: not a result of the episode
                        raise _write_failed(out_dir, OSError(not_written), len(new))
                    if line.get("scenario") is None:
                        line["scenario"] = loaded.name
                    try:
                        store.append(line)
                    except OSError as exc:
                        raise _write_failed(out_dir, exc, len(new)) from None
                    new.append(line)
                    progress.advance(line)
                    if line.get("snapshot_error") and warn is not None:
                        warn(f"seed {line['seed']}: no snapshot ({line['snapshot_error']})")
        finally:
            try:
                store.close()
            except OSError:
                pass  # the error that matters was raised above
            progress.stop()
        wall = time.perf_counter() - t0
        summary = summarize(
            finished + new,
            scenario=loaded.name,
            scenario_ref=ref,
            overrides=config.overrides,
            skill_paths=config.skill_paths,
            seed_base=config.seed_base,
            backend=backend.name,
            workers=backend.workers,
            wall_time_s=wall,
            episodes_run=len(new),
            results=store.path,
            # the re-run command records beside the episode's recording: not without one
            # (its folder is made by the first one saved)
            rrd_dir=None if no_recording or record == "none" else out_dir,
            allow_paths=allow,
        )
        try:
            _write_json(out_dir / SUMMARY, summary.to_json_dict())
        except OSError as exc:
            raise _write_failed(out_dir, exc, len(new)) from None
        return summary


def _write_failed(out_dir: Path, exc: OSError, recorded: int) -> BatchError:
    """The batch stops: a file of it cannot be written (a full disk, a quota)."""
    why = exc.strerror or str(exc)
    return BatchError(
        f"cannot write to {out_dir}: {why}; {recorded} episodes of this run were recorded, "
        f"none with a write error: free space, then continue with the same command plus "
        f"--resume --out {out_dir} (it runs every episode without a result)"
    )


def _record_mode(
    requested: RecordMode | None, no_recording: str | None, warn: Callable[[str], None] | None
) -> RecordMode:
    if requested == "none" or no_recording is None:
        return requested or "failures"
    if requested is None:
        if warn is not None:
            warn(f"recording is not available ({no_recording}): no .rrd files will be saved")
        return "none"
    raise BatchError(
        f"--record {requested} needs orchestrator.recording, which cannot be imported "
        f"({no_recording}); use --record none"
    )


def _check_out_dir(
    out_dir: Path, store: ResultsStore, manifest: dict[str, Any], resume: bool
) -> dict[int, dict[str, Any]]:
    existing = store.load(repair=False)
    if existing and not resume:
        raise BatchError(
            f"{store.path} already holds {len(existing)} episodes: pass --resume to continue "
            "that batch, or choose another --out"
        )
    path = out_dir / MANIFEST
    if resume and path.is_file():
        try:
            before = json.loads(path.read_text())
        except ValueError:
            before = None
        if before != manifest:
            raise BatchError(
                f"{out_dir} holds a batch of another scenario or other --set values "
                f"({before}); resume it with the same ones, or choose another --out"
            )
    if resume:
        existing = store.load(repair=True)  # cut a line torn by a crash
    return existing


def _write_json(path: Path, data: dict[str, Any]) -> None:
    """Write atomically: a crash leaves the old file or the new one, never half of one, and a
    failed write leaves no temporary file."""
    tmp = path.with_suffix(path.suffix + ".tmp")
    try:
        tmp.write_text(dumps(data, indent=2) + "\n")
        os.replace(tmp, path)
    except OSError:
        tmp.unlink(missing_ok=True)
        raise
