"""Bit-for-bit check of a change that should only remove work: dump runs' JSON, diff two dumps.

Runs a fixed set of (scenario, seed) episodes in one process and writes each run's JSON
(`RunResult.to_json_dict`, floats as Python prints them: every bit) without its wall-clock
fields, one file per run. Run it on the reference commit and on the change, then compare:

    python bench/bitwise.py --out /tmp/bits_main          # on the reference checkout
    python bench/bitwise.py --out /tmp/bits_new           # on the change
    python bench/bitwise.py --compare /tmp/bits_main /tmp/bits_new

The comparison prints, per run, `identical` or the first JSON paths that differ, and exits 1
if any differs.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

RUNS = [
    ("pick_place", 0),
    ("pick_place", 3),
    ("pick_place", 7),
    ("surgical", 0),
    ("sorting", 1),
    ("mobile_search", 1),
    ("mobile_search", 2),
]
"""The episodes compared: every scenario family's IK paths (fixed arm, whole body)."""

_WALL_KEYS = {"wall_time"}


def _strip_wall(value: Any) -> Any:
    """The JSON without wall-clock fields (they differ from run to run)."""
    if isinstance(value, dict):
        return {
            k: _strip_wall(v)
            for k, v in value.items()
            if k not in _WALL_KEYS and not k.startswith("wall_")
        }
    if isinstance(value, list):
        return [_strip_wall(v) for v in value]
    return value


def dump(out: Path) -> None:
    """Run every episode of `RUNS` and write its JSON to `out/<scenario>_<seed>.json`."""
    from orchestrator.engine.runner import run_episode
    from orchestrator.language.load import load_scenario

    out.mkdir(parents=True, exist_ok=True)
    for scenario, seed in RUNS:
        result = run_episode(load_scenario(scenario), seed)
        data = _strip_wall(result.to_json_dict())
        (out / f"{scenario}_{seed}.json").write_text(json.dumps(data, indent=1, sort_keys=True))
        print(f"{scenario} seed {seed}: {result.outcome}, sim {result.sim_time:.2f} s", flush=True)


def _diff(a: Any, b: Any, path: str, found: list[str]) -> None:
    """Append to `found` the JSON paths where `a` and `b` differ."""
    if isinstance(a, dict) and isinstance(b, dict):
        for key in sorted(set(a) | set(b)):
            _diff(a.get(key), b.get(key), f"{path}.{key}", found)
    elif isinstance(a, list) and isinstance(b, list) and len(a) == len(b):
        for i, (x, y) in enumerate(zip(a, b, strict=True)):
            _diff(x, y, f"{path}[{i}]", found)
    elif a != b:
        found.append(f"{path}: {a!r} != {b!r}")


def compare(ref: Path, new: Path) -> int:
    """Print per run whether the two dumps are identical; 1 if any differs, else 0."""
    status = 0
    for scenario, seed in RUNS:
        name = f"{scenario}_{seed}.json"
        a = json.loads((ref / name).read_text())
        b = json.loads((new / name).read_text())
        found: list[str] = []
        _diff(a, b, "", found)
        if found:
            status = 1
            print(f"{name}: {len(found)} differences, first: " + "; ".join(found[:3]))
        else:
            print(f"{name}: identical")
    return status


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, help="write the runs' JSON here")
    parser.add_argument("--compare", type=Path, nargs=2, metavar=("REF", "NEW"))
    args = parser.parse_args()
    if args.compare:
        sys.exit(compare(*args.compare))
    if args.out is None:
        parser.error("give --out DIR or --compare REF NEW")
    dump(args.out)


if __name__ == "__main__":
    main()
