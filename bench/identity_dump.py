"""Dump the run JSON of a fixed set of episodes and fault matrices, to diff two checkouts.

A change that only removes work (same arithmetic) must leave every result bit for bit the
same: run this on both checkouts and diff the files (wall-clock fields are dropped; floats are
compared as JSON prints them: every bit). A difference is reported with the first JSON paths
where the two differ.

    python bench/identity_dump.py OUT.json            # on main, then on the branch
    python bench/identity_dump.py OUT.json --diff MAIN.json
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

RUNS = [
    ("pick_place", 0),
    ("pick_place", 3),
    ("pick_place", 7),
    ("surgical", 0),
    ("surgical_complication", 0),
    ("sorting", 1),
    ("mobile_search", 1),
    ("mobile_search", 2),
    ("pick_place_vision", 0),
    ("stack", 0),
    ("sorting_conveyor", 0),
    ("reach_random", 0),
]
"""One or more runs of every bundled scenario (orchestrator/scenarios/)."""
MATRICES = ["pick_place", "surgical"]
WALL_KEYS = {"wall_time", "wall_time_s", "rtf", "realtime_factor", "cpu_time_s"}


def _scrub(value: object) -> object:
    """Drop the wall-clock fields (they differ between any two runs)."""
    if isinstance(value, dict):
        return {k: _scrub(v) for k, v in value.items() if k not in WALL_KEYS}
    if isinstance(value, list):
        return [_scrub(v) for v in value]
    return value


def _cli(*args: str) -> object:
    out = subprocess.run(
        [sys.executable, "-m", "orchestrator.cli", *args, "--json"],
        capture_output=True,
        text=True,
        check=False,
    )
    return _scrub(json.loads(out.stdout))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path, help="where to write the results")
    parser.add_argument("--diff", type=Path, help="results of the other checkout to compare")
    args = parser.parse_args()
    results: dict[str, object] = {}
    for name, seed in RUNS:
        results[f"run {name} {seed}"] = _cli("run", name, "--seed", str(seed))
        print(f"run {name} --seed {seed}", file=sys.stderr)
    for name in MATRICES:
        results[f"faults {name}"] = _cli("faults", name)
        print(f"faults {name}", file=sys.stderr)
    args.out.write_text(json.dumps(results, indent=1, sort_keys=True))
    if args.diff is None:
        return
    other = json.loads(args.diff.read_text())
    status = 0
    for key, value in results.items():
        found: list[str] = []
        _differences(other.get(key), value, "", found)
        if found:
            status = 1
            print(f"{key:32s} DIFFERS in {len(found)} places, first: " + "; ".join(found[:3]))
        else:
            print(f"{key:32s} identical")
    sys.exit(status)


def _differences(a: object, b: object, path: str, found: list[str]) -> None:
    """Append to `found` the JSON paths where `a` and `b` differ."""
    if isinstance(a, dict) and isinstance(b, dict):
        for key in sorted(set(a) | set(b)):
            _differences(a.get(key), b.get(key), f"{path}.{key}", found)
    elif isinstance(a, list) and isinstance(b, list) and len(a) == len(b):
        for i, (x, y) in enumerate(zip(a, b, strict=True)):
            _differences(x, y, f"{path}[{i}]", found)
    elif a != b or type(a) is not type(b):
        found.append(f"{path}: {a!r} != {b!r}")


if __name__ == "__main__":
    main()
