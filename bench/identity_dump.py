"""Dump the run JSON of a fixed set of episodes and fault matrices, to diff two checkouts.

A change that only removes work (same arithmetic) must leave every result bit for bit the
same: run this on both checkouts and diff the files (wall-clock fields are dropped).

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
]
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
    same = {
        k: json.dumps(v, sort_keys=True) == json.dumps(other.get(k), sort_keys=True)
        for k, v in results.items()
    }
    differ = [k for k, ok in same.items() if not ok]
    for key in results:
        print(f"{key:32s} {'DIFFERS' if key in differ else 'identical'}")
    sys.exit(1 if differ else 0)


if __name__ == "__main__":
    main()
