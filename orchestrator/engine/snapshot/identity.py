"""Is a resumed run the uninterrupted run? The check tests/test_snapshot.py and
bench/snapshot_identity.py run on every bundled scenario.

`reference` runs an episode once, listening to every state entry, and picks break points
from it: an entry inside a parallel state, a retry, an entry inside a nested machine, a
guard's abort, one near the middle, and control ticks at a third and two thirds of the run
(at least `MIN_CASES` distinct ticks). `check` runs the episode again to one of them, writes
the snapshot file, reads it back (verified, as `run --from` does), runs it to the end and
compares the result with the reference: the `run --json` object minus its wall time.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ...language.load import LoadedScenario
from ...language.loading import MachineNode
from ...language.machine import SAFE_STOP
from ..result import RunResult
from ..runner import drive, new_run
from .breaks import state_paths
from .run_snapshot import load_run, write_run
from .stops import EntryLog, Stop, run_to

__all__ = ["MIN_CASES", "Case", "Outcome", "check", "comparable", "reference"]

MIN_CASES = 3
_KINDS = ("parallel", "retry", "guard", "nested", "entry")


@dataclass(frozen=True)
class Case:
    """A break point to check: `kind` says what happens in its tick (`parallel`, `retry`,
    `nested`, `guard`, `entry`, `time`)."""

    kind: str
    stop: Stop


@dataclass(frozen=True)
class Outcome:
    """One case checked.

    Attributes:
        case: The break point.
        identical: The resumed run's result equals the uninterrupted one's.
        difference: The first key that differs (None if identical).
        size: The snapshot file [bytes].
        write_s: Record, compress, sign and write it [s].
        load_s: Read, verify, rebuild and check it [s].
        t: Simulated time of the snapshot [s].
    """

    case: Case
    identical: bool
    difference: str | None
    size: int
    write_s: float
    load_s: float
    t: float


def comparable(result: RunResult) -> dict[str, Any]:
    """The `run --json` object without what differs between two runs of one episode (the
    wall time)."""
    out = result.to_json_dict()
    out.pop("wall_time", None)
    out.pop("invariants", None)  # a resumed run measures them from the resume on (its `from_t`)
    return out


def _parallel_prefixes(machine: MachineNode) -> list[str]:
    """Dotted paths of the parallel states of the tree, each followed by a dot."""
    out = []
    for path in state_paths(machine):
        node, name = _state(machine, path)
        if node is not None and name in node.branches:
            out.append(path + ".")
    return out


def _state(machine: MachineNode, path: str) -> tuple[MachineNode | None, str]:
    node: MachineNode | None = machine
    parts = path.split(".")
    i = 0
    while node is not None and i < len(parts) - 1:
        name = parts[i]
        if name in node.children:
            node, i = node.children[name], i + 1
        elif name in node.branches and parts[i + 1] in node.branches[name]:
            branch = node.branches[name][parts[i + 1]]
            node, i = (branch if isinstance(branch, MachineNode) else None), i + 2
        else:
            return None, ""
    return node, parts[-1]


def reference(loaded: LoadedScenario, seed: int) -> tuple[RunResult, list[Case]]:
    """The uninterrupted run's result and the break points to check it at."""
    run = new_run(loaded, seed)
    log = EntryLog(run)
    run.executor.entry_listeners.append(log)
    result = drive(run)
    assert result is not None
    ticks = run.ctx.tick
    parallel = _parallel_prefixes(loaded.machine)
    picks: dict[str, tuple[int, bool, str]] = {}
    later = [e for e in log.entries if not e[1]]  # entries after the start
    opened: dict[str, int] = {}  # parallel state -> tick of its (last) entry
    for tick, _, path, retry in later:
        if path + "." in parallel:
            opened[path + "."] = tick
        inside = next((p for p in parallel if path.startswith(p)), None)
        # inside a parallel state while its branches run (not as it is entered)
        if "parallel" not in picks and inside is not None and tick > opened.get(inside, tick):
            picks["parallel"] = (tick, False, f"entry of {path}")
        if "retry" not in picks and retry:
            picks["retry"] = (tick, False, f"retry {retry} of {path}")
        if "guard" not in picks and path == SAFE_STOP:
            picks["guard"] = (tick, False, "a guard's abort")
        if "nested" not in picks and "." in path and not any(path.startswith(p) for p in parallel):
            picks["nested"] = (tick, False, f"entry of {path}")
    if later:
        tick, _, path, _ = min(later, key=lambda e: abs(e[0] - ticks // 2))
        picks.setdefault("entry", (tick, False, f"entry of {path}"))
    cases: list[Case] = []
    seen: set[int] = set()
    for kind in _KINDS:  # one tick each, the rarer kinds first
        if kind not in picks:
            continue
        tick, before, reason = picks[kind]
        if tick not in seen and tick < ticks:
            seen.add(tick)
            cases.append(Case(kind, Stop(tick, before, reason, f"identity: {kind}")))
    for fraction in (1 / 3, 2 / 3, 1 / 6, 5 / 6):
        if len(seen) >= MIN_CASES + 1:
            break
        tick = int(ticks * fraction)
        if tick not in seen and 0 < tick < ticks:
            seen.add(tick)
            stop = Stop(tick, False, f"control tick {tick}", "identity: time")
            cases.append(Case("time", stop))
    return result, cases


def check(
    loaded: LoadedScenario, seed: int, case: Case, expected: dict[str, Any], folder: Path
) -> Outcome:
    """Break at `case`, write the snapshot into `folder`, read it back, run it to the end and
    compare with `expected` (`comparable` of the reference)."""
    run = new_run(loaded, seed)
    if not run_to(run, case.stop):
        raise AssertionError(f"the run ended before {case.stop.reason}")
    path = Path(folder) / f"{loaded.name}-seed{seed}-tick{case.stop.tick}.snap"
    wall0 = time.perf_counter()
    size = write_run(path, run, case.stop.header(), [])
    write_s = time.perf_counter() - wall0
    t = run.ctx.t
    del run
    snap = load_run(path)
    result = drive(snap.run)
    assert result is not None
    got = comparable(result)
    diff = next((k for k in expected if expected[k] != got.get(k)), None)
    if diff is None and set(got) != set(expected):
        diff = f"keys {sorted(set(got) ^ set(expected))}"
    return Outcome(case, diff is None, diff, size, write_s, snap.load_s, t)
