"""What a counterexample leaves to look at: a Rerun recording of the minimal run and a snapshot
just before its first violation (the project's own recorder and snapshot machinery).

The snapshot is taken at the start of the control tick before the one the first invariant
violation happened in (a time break point, engine/snapshot); a failed success check has no
instant, so its snapshot is the one `batch --snapshot-on-failure` keeps: the start of the tick
of the last state entry before the failure. `orchestrator run --from SNAP` resumes either.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..engine.invariants import first_violation
from ..engine.prepare import prepare
from ..engine.runner import drive
from ..engine.snapshot import (
    BreakPoint,
    EntryLog,
    find_stop,
    last_entry_stop,
    local_skill_files,
    run_to,
    write_run,
)
from ..engine.snapshot.breaks import final_paths
from .verdict import failures, message

if TYPE_CHECKING:
    from .params import Parameter
    from .sampler import Variation

__all__ = ["keep_artifacts"]


def keep_artifacts(
    ref: str,
    var: Variation,
    params: Mapping[str, Parameter],
    name: str,
    where: Path,
    base: Path,
    allow: tuple[str, ...] = (),
    max_wall_s: float | None = None,
    warn: Callable[[str], None] | None = None,
) -> dict[str, Any]:
    """Record the minimal run of `var` (failing with `name`) and snapshot it before its first
    violation, into the folder `where`.

    Returns:
        `rrd` and `snapshot` (paths relative to `base`, the exploration's directory),
        `snapshot_at` and the minimal run's `message`, or `artifact_error` saying why one is
        missing (the counterexample stands either way).
    """
    out: dict[str, Any] = {}
    try:
        where.mkdir(parents=True, exist_ok=True)
        seed, sets = var.seed, var.overrides(params)
        prepared = prepare(ref, seed, sets, allow_paths=allow)
        observers: list[Any] = []
        rrd = where / "minimal.rrd"
        try:
            from ..recording import RerunRecorder  # type: ignore[import-not-found]

            observers.append(RerunRecorder(path=rrd, spawn=False))
        except ImportError as exc:
            out["artifact_error"] = f"no recording: {exc}"
        result = prepared.run_episode(observers, max_wall_s)
        line = result.to_json_dict()
        if observers:
            out["rrd"] = str(rrd.relative_to(base))
        if name not in failures(line):
            out["artifact_error"] = f"the recorded run did not show {name} again"
            return out
        out["message"] = message(line, name)  # the minimal run's own words
        first = first_violation(result.invariants)
        snap = where / "before.snap"
        if first is not None and name.startswith("invariant:"):
            dt = 1.0 / prepared.loaded.scenario.physics.control_hz
            at_t = max(0.0, float(first["t"]) - dt)
            again = prepare(ref, seed, sets, allow_paths=allow)
            stop, _ = find_stop(again.new_run(), [BreakPoint(f"--break-at {at_t:g}", at_t=at_t)])
            if stop is None:
                out["artifact_error"] = "the re-run ended before the violation"
                return out
            run = prepare(ref, seed, sets, allow_paths=allow).new_run()
        else:
            again = prepare(ref, seed, sets, allow_paths=allow)
            run = again.new_run()
            log = EntryLog(run)
            run.executor.entry_listeners.append(log)
            drive(run)
            stop = last_entry_stop(log, final_paths(again.loaded.machine).__contains__)
            if stop is None:
                out["artifact_error"] = "no state was entered before the failure"
                return out
            run = prepare(ref, seed, sets, allow_paths=allow).new_run()
        if not run_to(run, stop):
            out["artifact_error"] = "the re-run ended before the snapshot's tick"
            return out
        write_run(snap, run, stop.header(), local_skill_files())
        out["snapshot"] = str(snap.relative_to(base))
        out["snapshot_at"] = stop.reason
    except Exception as exc:  # the counterexample stands; say why an artifact is missing
        out["artifact_error"] = f"{type(exc).__name__}: {str(exc).strip().splitlines()[0]}"
        if warn is not None:
            warn(f"counterexample {var.k}: {out['artifact_error']}")
    return out
