"""Start-up: what a command costs before it does anything, measured as a user runs it.

Each command runs as its own process (the console script `orchestrator` next to this Python),
N times, interleaved (run 1 of every command, then run 2, ...) so that a change in the
machine's load hits every command alike. Printed per command: the median wall time and the
median CPU time (user + system of the child, from `resource.getrusage`), with two references
measured in the same rounds: `python -c pass` (the interpreter alone) and
`python -c 'import numpy'` (the one library every command needs). The load average
(`os.getloadavg`) is printed before and after: on a shared machine the wall figures grow with
it, the CPU figures much less.

The commands:

* `orchestrator --version`
* `orchestrator validate scenarios/pick_place.yaml` (a bundled scenario: its machine, its
  includes, every check, and MuJoCo compiling its scene once)
* `orchestrator validate machines/reach.yaml` (a bundled machine: one `move`, a blackboard)
* `orchestrator validate tests/machines/small_move.yaml` (a user's first machine: one `move`;
  the language layer and the skills' declarations, no physics)

Bytecode: an installed package carries its compiled `.pyc` files, so by default the children
run with a bytecode cache of their own (`PYTHONPYCACHEPREFIX`, a temporary directory; one
untimed round fills it) even when this shell sets `PYTHONDONTWRITEBYTECODE`. `--no-bytecode`
runs them with this shell's environment unchanged: with `PYTHONDONTWRITEBYTECODE=1` and no
`__pycache__` beside the sources, every run compiles every module it imports from source.

Where `validate small_move.yaml`'s CPU time goes is measured in the same rounds: a fresh
interpreter imports numpy, pydantic, the CLI (typer, rich), the language layer's modules that
validating a machine imports (with the guards' declarations), discovers the skills and the
success checks, then runs the command, reading `time.process_time` between stages (each stage
pays only for what the ones before it did not load).

Each command must exit 0; the bench stops with the command's output otherwise.

    python bench/startup.py [--runs 11] [--no-bytecode]
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
SMALL_MACHINE = REPO / "tests" / "machines" / "small_move.yaml"
"""The small user file `validate` is timed on: one skill state, two final states."""


STAGES = """\
import json, sys, time
marks = [("interpreter", time.process_time())]
def mark(name):
    marks.append((name, time.process_time()))
import numpy
mark("numpy")
import pydantic
from pydantic import BaseModel
mark("pydantic")
import orchestrator.cli
mark("the CLI: typer, rich")
import orchestrator.language.validate_paths
mark("the language layer (a machine's modules) and the guards' declarations")
from orchestrator.skills import skill_names
skill_names()
mark("the skills' declarations")
from orchestrator.success import check_kinds
check_kinds()
mark("the success checks' declarations")
sys.argv = ["orchestrator", "validate", sys.argv[1]]
try:
    orchestrator.cli.main()
except SystemExit as exc:
    assert not exc.code, exc.code
mark("validating the file")
out = {marks[0][0]: marks[0][1]}
out.update({b[0]: b[1] - a[1] for a, b in zip(marks, marks[1:])})
print(json.dumps(out))
"""
"""The stages of `validate` in one interpreter: CPU seconds each added."""


def _console_script() -> str:
    """The `orchestrator` console script installed next to this interpreter."""
    beside = Path(sys.executable).with_name("orchestrator")
    found = beside if beside.exists() else shutil.which("orchestrator")
    if found is None:
        raise SystemExit("no `orchestrator` console script: pip install -e . first")
    return str(found)


def _timed(cmd: list[str], cwd: Path, env: dict[str, str]) -> tuple[float, float]:
    """Run `cmd` once; its wall time and CPU time (user + system) [s]."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, cwd=cwd, env=env, capture_output=True, text=True, check=False)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if proc.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} exited {proc.returncode}:\n{proc.stdout}{proc.stderr}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu


def _stages(cwd: Path, env: dict[str, str]) -> dict[str, float]:
    """CPU seconds of each stage of `validate small_move.yaml` (`STAGES`), one run."""
    cmd = [sys.executable, "-c", STAGES, str(SMALL_MACHINE)]
    proc = subprocess.run(cmd, cwd=cwd, env=env, capture_output=True, text=True, check=False)
    if proc.returncode != 0:
        raise SystemExit(f"the stages of validate failed:\n{proc.stdout}{proc.stderr}")
    stages: dict[str, float] = json.loads(proc.stdout.splitlines()[-1])
    return stages


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=int, default=11, help="runs of each command")
    parser.add_argument(
        "--no-bytecode", action="store_true", help="run with this environment unchanged"
    )
    args = parser.parse_args()

    cli = _console_script()
    with tempfile.TemporaryDirectory() as tmp:
        commands = {
            "python -c pass": [sys.executable, "-c", "pass"],
            "python -c 'import numpy'": [sys.executable, "-c", "import numpy"],
            "orchestrator --version": [cli, "--version"],
            "orchestrator validate scenarios/pick_place.yaml": [
                cli, "validate", str(REPO / "scenarios" / "pick_place.yaml"),
            ],
            "orchestrator validate machines/reach.yaml": [
                cli, "validate", str(REPO / "machines" / "reach.yaml"),
            ],
            "orchestrator validate small_move.yaml (a user's file)": [
                cli, "validate", str(SMALL_MACHINE),
            ],
        }  # fmt: skip
        env = dict(os.environ)
        if args.no_bytecode:
            flag = env.get("PYTHONDONTWRITEBYTECODE")
            mode = f"environment unchanged (PYTHONDONTWRITEBYTECODE={flag})"
        else:
            env.pop("PYTHONDONTWRITEBYTECODE", None)
            env["PYTHONPYCACHEPREFIX"] = str(Path(tmp) / "pycache")
            mode = "bytecode cached (as installed)"
            for cmd in commands.values():
                _timed(cmd, Path(tmp), env)
        load_before = os.getloadavg()
        walls: dict[str, list[float]] = {name: [] for name in commands}
        cpus: dict[str, list[float]] = {name: [] for name in commands}
        stages: dict[str, list[float]] = {}
        for _ in range(args.runs):
            for name, cmd in commands.items():
                wall, cpu = _timed(cmd, Path(tmp), env)
                walls[name].append(wall)
                cpus[name].append(cpu)
            for stage, cpu in _stages(Path(tmp), env).items():
                stages.setdefault(stage, []).append(cpu)
        load_after = os.getloadavg()

    print(f"load average (1, 5, 15 min): before {load_before}, after {load_after}")
    print(f"median of {args.runs} runs each, interleaved; {mode}\n")
    print("| command | wall [s] | CPU [s] |")
    print("|---|---|---|")
    for name in commands:
        print(f"| `{name}` | {statistics.median(walls[name]):.3f} | "
              f"{statistics.median(cpus[name]):.3f} |")  # fmt: skip
    print("\nwhere `validate small_move.yaml` spends its CPU, stage by stage (median)\n")
    print("| stage | CPU [s] |")
    print("|---|---|")
    for stage, values in stages.items():
        print(f"| {stage} | {statistics.median(values):.3f} |")


if __name__ == "__main__":
    main()
