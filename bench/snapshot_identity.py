"""Does a snapshot resume bit for bit? Every bundled scenario, broken at >= 3 points each.

For each scenario (seed 0; pick_place once more with `perception_miss@0`, which makes PICK
retry, and tests/machines/parallel_pick.yaml, which has a retry, a parallel state and nested
machines), the episode runs once uninterrupted while every state entry is noted; break points
are picked from it (an entry inside a parallel state, a retry, a guard's abort, an entry
inside a nested machine, one near the middle, ticks at 1/3 and 2/3 of the run: at least 3
distinct ticks). For each, a fresh episode runs to the start of that tick, the snapshot is
written to a file (recorded as data, compressed, signed), read back (verified, rebuilt,
checked) and run to the end; its `run --json` object minus the wall time must equal the
uninterrupted run's. A snapshot is data (a JSON header and an .npz of arrays): reading it
back rebuilds the run from the scenario, drives it to the snapshot's tick and checks it holds
the recorded state, so "read" includes that replay.

Reported per break point: identical or not (and the first key that differs), the file's size,
the time to write it and to read it back (wall time: report them with the machine's load),
and the time to re-simulate the episode from t = 0 to there alone (the replay a resume now
does, without reading and checking). `--cross-process` also resumes one snapshot per scenario with
`orchestrator run --from` in a fresh process (another PYTHONHASHSEED).

    python bench/snapshot_identity.py                   # the table (markdown) and a verdict
    python bench/snapshot_identity.py --json out.json   # every figure as JSON too
    python bench/snapshot_identity.py --only pick_place --cross-process

Exit status 0 when every break point resumed identically, 1 otherwise.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from orchestrator.engine.runner import new_run
from orchestrator.engine.snapshot.identity import check, comparable, reference
from orchestrator.engine.snapshot.stops import run_to
from orchestrator.language.bundled import bundled_names
from orchestrator.language.load import load_scenario

REPO = Path(__file__).resolve().parent.parent
PARALLEL_PICK = str(REPO / "tests" / "machines" / "parallel_pick.yaml")
EXTRA = [("pick_place", ["perception_miss@0"]), (PARALLEL_PICK, ["perception_miss@0"])]
"""Besides every bundled scenario as it is: a retry, and a parallel state."""


def matrix() -> list[tuple[str, list[str]]]:
    return [(name, []) for name in bundled_names("scenarios")] + EXTRA


def _label(name: str, faults: list[str]) -> str:
    return Path(name).stem + (f" + {' '.join(faults)}" if faults else "")


def _cross_process(path: Path, expected: dict, key_home: str) -> bool | str:
    """True when `orchestrator run --from` in a fresh process ends as `expected`; else False,
    or what it said when it refused (a snapshot is refused, e.g., when the code changed)."""
    env = {**os.environ, "PYTHONHASHSEED": "12345", "XDG_CONFIG_HOME": key_home}
    proc = subprocess.run(
        [sys.executable, "-m", "orchestrator.cli", "run", "--from", str(path), "--json"],
        capture_output=True, text=True, check=False, env=env,
    )  # fmt: skip
    try:
        got = json.loads(proc.stdout)
    except ValueError:
        return " ".join(proc.stderr.split())[:200] or f"exit {proc.returncode}"
    got.pop("wall_time", None)
    return got == expected


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", type=Path, help="write every figure here")
    parser.add_argument("--only", action="append", help="a scenario (repeatable)")
    parser.add_argument("--cross-process", action="store_true", help="resume one per scenario "
                        "in a fresh `orchestrator run --from` process")  # fmt: skip
    args = parser.parse_args()
    folder = Path(tempfile.mkdtemp(prefix="snapshot-identity-"))
    key_home = str(folder / "config")
    os.environ["XDG_CONFIG_HOME"] = key_home  # a key of its own, not the user's
    rows, all_ok = [], True
    print(f"load average at start: {os.getloadavg()[0]:.1f} ({os.cpu_count()} cores)")
    for name, faults in matrix():
        if args.only and Path(name).stem not in args.only:
            continue
        loaded = load_scenario(name, faults=faults)
        wall0 = time.perf_counter()
        result, cases = reference(loaded, 0)
        run_s = time.perf_counter() - wall0
        expected = comparable(result)
        for i, case in enumerate(cases):
            replay0 = time.perf_counter()
            assert run_to(new_run(loaded, 0), case.stop)
            replay_s = time.perf_counter() - replay0
            outcome = check(loaded, 0, case, expected, folder)
            row = {
                "scenario": _label(name, faults),
                "outcome": result.outcome,
                "sim_time_s": result.sim_time,
                "run_s": round(run_s, 3),
                "kind": case.kind,
                "tick": case.stop.tick,
                "t": round(outcome.t, 4),
                "break": case.stop.reason,
                "identical": outcome.identical,
                "difference": outcome.difference,
                "bytes": outcome.size,
                "write_s": round(outcome.write_s, 4),
                "load_s": round(outcome.load_s, 4),
                "replay_s": round(replay_s, 4),
            }
            if args.cross_process and i == 0:
                snap = folder / f"{loaded.name}-seed0-tick{case.stop.tick}.snap"
                row["cross_process_identical"] = _cross_process(snap, expected, key_home)
                all_ok = all_ok and row["cross_process_identical"] is True
            all_ok = all_ok and outcome.identical
            rows.append(row)
            other = row.get("cross_process_identical")
            print(
                f"{row['scenario']:42s} {case.kind:8s} t={row['t']:7.3f} "
                f"{'identical' if outcome.identical else 'DIFFERS: ' + str(outcome.difference)}"
                f"  {outcome.size / 1e6:.2f} MB  write {outcome.write_s * 1e3:4.0f} ms  "
                f"read {outcome.load_s * 1e3:4.0f} ms  replay {replay_s * 1e3:5.0f} ms"
                + (
                    ""
                    if other is None
                    else f"  another process: {'identical' if other is True else other}"
                ),
                flush=True,
            )
    print(f"load average at end: {os.getloadavg()[0]:.1f}")
    _table(rows)
    if args.json:
        args.json.write_text(json.dumps({"rows": rows, "identical": all_ok}, indent=1) + "\n")
    n_ok = sum(r["identical"] for r in rows)
    print(f"\n{n_ok} of {len(rows)} break points resumed identically over "
          f"{len({r['scenario'] for r in rows})} scenarios")  # fmt: skip
    return 0 if all_ok else 1


def _table(rows: list[dict]) -> None:
    """Per scenario: break points, identical, size, write and read time (median, max)."""
    print("\n| scenario | break points (kinds) | identical | size [MB] | write [ms] | "
          "read [ms] | replay to the break [ms] |")  # fmt: skip
    print("|---|---|---|---|---|---|---|")
    for scenario in dict.fromkeys(r["scenario"] for r in rows):
        mine = [r for r in rows if r["scenario"] == scenario]
        kinds = ", ".join(sorted({r["kind"] for r in mine}))

        def span(key: str, scale: float, mine: list[dict] = mine) -> str:
            values = [r[key] * scale for r in mine]
            return f"{statistics.median(values):.0f} (max {max(values):.0f})"

        size = statistics.median(r["bytes"] for r in mine) / 1e6
        print(f"| {scenario} | {len(mine)} ({kinds}) | {sum(r['identical'] for r in mine)}/"
              f"{len(mine)} | {size:.2f} | {span('write_s', 1e3)} | {span('load_s', 1e3)} | "
              f"{span('replay_s', 1e3)} |")  # fmt: skip


if __name__ == "__main__":
    sys.exit(main())
