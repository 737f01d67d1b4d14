"""Input fuzzing campaign: every hostile input class and thousands of mutated files through
`orchestrator validate`, and bad `run`/`batch` invocations, each answered in-process.

Figures: how many answers were tracebacks, exit codes other than 0/2, messages without a real
`file:line:col` (line and column >= 1), and the answer times (median, 99th percentile, max;
wall and CPU seconds; the target is under 2 s each). The interpreter's start-up (imports) is
measured once apart: it is the same for every command.

    python bench/fuzz_campaign.py [--mutations 2334] [--seed 10]
"""

from __future__ import annotations

import argparse
import random
import re
import statistics
import subprocess
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path

from typer.testing import CliRunner

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from orchestrator.cli import app  # noqa: E402
from tests.hostile import every_hostile, final_start_retry, random_mutation, write_bundled  # noqa: E402

POSITION = re.compile(r"^.+?:(\d+):(\d+): \S")
SUMMARY = re.compile(r"^\d+ errors?; ")
TARGET_S = 2.0


def _bad_invocations(scratch: Path) -> list[list[str]]:
    """Bad `run` and `batch` command lines: options out of range, wrong types, paths that are
    not what they should be, overrides with absurd values, malformed faults."""
    (scratch / "dir.rrd").mkdir()
    retry = final_start_retry().write(scratch / "retry")
    runs: list[list[str]] = []
    for seed in ["-1", "-99999", "1" * 25, "abc", "1.5", "nan", ""]:
        runs.append(["--seed", seed])
    for wall in ["0", "-1", "nan", "inf", "abc"]:
        runs.append(["--max-wall-s", wall])
    for rrd in [
        str(scratch / "dir.rrd"),
        "/proc/issue10/x.rrd",
        "/proc/version",
        str(scratch / "no" / "such" / "x.rrd"),  # issue 26: refused, never created
    ]:
        runs.append(["--rrd", rrd])
    for allow in ["/nonexistent", "/etc/passwd"]:
        runs.append(["--allow-path", allow])
    for override in [
        "physics.timestep_s=1e-300",
        "physics.timestep_s=nan",
        "physics.control_hz=1e-6",
        "physics.control_hz=-1",
        "physics.time_limit_s=1e300",
        "physics.time_limit_s=.inf",
        "scene.table.size_xy=[-0.7,0.9]",
        "scene.objects[0].size=[1e-300,0.05,0.05]",
        "scene.objects[0].mass=1e300",
        "machine=surgical_typo",
        "machine=../../../etc/passwd",
        "machine=/etc/shadow",
        "machine=" + "a" * 5000,
        "nokey=1",
        "noequals",
        "=1",
        "physics=1",
        "physics.timestep_s=!!python/object/apply:os.system [ls]",
        "physics.timestep_s=[1,2]",
        "physics.timestep_s=" + "1" * 5000,
        "guards=&a [*a]",
        "physics.timestep_s=\x00",
        "place_at=NaN",  # issue 26: goals spelled as text
        "place_at=[1e308,0,0.3]",
        "place_at=[1.0e+308,0,0.3]",
    ]:
        runs.append(["--set", override])
    for fault in [
        "bogus@1", "estop@nan", "estop@-1", "estop@1e300", "ft_bias", "@", "x" * 5000,
        # issue 26: overflow and parser bombs in fault values
        "perception_offset:offset_m=[1e308,0,0]@0",
        "push:object=cube,force_n=[1.0e+308,0,0]@0.5",
        "perception_miss:count=" + "1" * 5000 + "@0",
        "push:object=cube,force_n=" + "[" * 3000 + "]" * 3000 + "@0",
    ]:  # fmt: skip
        runs.append(["--fault", fault])
    for event in ["1e400:estop", "nan:estop", "-1:pause"]:
        runs.append(["--event", event])
    cases = [["run", "pick_place", *r] for r in runs]
    for scenario in [
        "nonexistent",
        "a" * 5000,
        "/etc/passwd",
        "/dev/zero",
        "/tmp",
        "../../etc/shadow",
        "\x00",
        "[bold]x[/]:100:",
    ]:
        cases.append(["run", scenario])
    for args in [
        ["-n", "0"],
        ["-n", "-1"],
        ["-n", "2", "--seed-base", "-5"],
        ["-n", "2", "--seed-base", str(2**63 - 1)],
        ["-n", "2", "--workers", "0"],
        ["-n", "2", "--out", "/etc/passwd"],
        ["-n", "2", "--resume"],
        ["-n", "2", "--backend", "nope"],
        ["-n", "2", "--address", "ray://x"],
        ["-n", "2", "--record", "sometimes"],
        ["-n", "2", "--max-wall-s", "0"],
        ["-n", "2", "--set", "physics.control_hz=1e-6"],
    ]:
        cases.append(["batch", "pick_place", *args])
    cases += [
        ["graph", "pick_place", "--format", "[red]x"],
        ["schema", "nope"],
        ["validate", "pick_place", "--allow-path", "/nonexistent"],
        ["faults", "pick_place", "--seed", "-1"],
    ]
    return [c for c in cases if c] + [["run", str(retry), "--json", "--max-wall-s", "60"]]


class Tally:
    """Answers of one kind: counts and times."""

    def __init__(self) -> None:
        self.n = 0
        self.tracebacks: list[str] = []
        self.bad_exit: list[str] = []
        self.bad_position: list[str] = []
        self.wall: list[float] = []
        self.cpu: list[float] = []
        self.exits: Counter[int] = Counter()

    def line(self, name: str) -> str:
        w = sorted(self.wall)
        p99 = w[min(len(w) - 1, int(0.99 * len(w)))]
        slow = sum(t > TARGET_S for t in self.cpu)
        return (
            f"{name:22} {self.n:5d} answers | tracebacks {len(self.tracebacks)} | exit not 0/2 "
            f"{len(self.bad_exit)} | no file:line:col {len(self.bad_position)} | wall median "
            f"{statistics.median(w):.3f} s p99 {p99:.3f} s max {max(w):.3f} s | cpu max "
            f"{max(self.cpu):.3f} s, over {TARGET_S:g} s: {slow} | exits {dict(self.exits)}"
        )


def _answer(
    runner: CliRunner,
    args: list[str],
    tally: Tally,
    label: str,
    entry: Path | None,
    ok_exits: tuple[int, ...] = (0, 2),
) -> None:
    w0, c0 = time.perf_counter(), time.process_time()
    res = runner.invoke(app, args, catch_exceptions=True)
    tally.wall.append(time.perf_counter() - w0)
    tally.cpu.append(time.process_time() - c0)
    tally.n += 1
    tally.exits[res.exit_code] += 1
    exc = res.exception if not isinstance(res.exception, SystemExit) else None
    if exc is not None or "Traceback" in res.stderr:
        tally.tracebacks.append(f"{label}: {exc!r}")
    if res.exit_code not in ok_exits:
        tally.bad_exit.append(f"{label}: exit {res.exit_code}")
    if entry is not None and res.exit_code == 2:
        for line in res.stderr.splitlines():
            if not line.strip() or SUMMARY.match(line):
                continue
            m = POSITION.match(line)
            if not m or int(m[1]) < 1 or int(m[2]) < 1:
                tally.bad_position.append(f"{label}: {line[:160]}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--mutations", type=int, default=2334)
    parser.add_argument("--seed", type=int, default=10)
    args = parser.parse_args()
    runner = CliRunner()
    rng = random.Random(args.seed)
    with tempfile.TemporaryDirectory(prefix="fuzz-") as tmp:
        root = Path(tmp)
        _answer(runner, ["validate", "pick_place"], Tally(), "warm-up", None)  # imports
        hostile, mutated, invocations = Tally(), Tally(), Tally()
        for i, h in enumerate(every_hostile()):
            case = root / f"h{i}"
            entry = h.write(case)
            _answer(runner, ["validate", str(entry)], hostile, h.name, entry)
        for i in range(args.mutations):
            case = root / f"m{i}"
            case.mkdir()
            which, data = random_mutation(rng)
            entry = write_bundled(case, which, data)
            _answer(runner, ["validate", str(entry)], mutated, f"mutation {i} of {which}", entry)
        bad = _bad_invocations(root)
        for argv in bad[:-1]:
            _answer(runner, argv, invocations, " ".join(argv)[:100], None, (2,))
        _answer(runner, bad[-1], invocations, "retry 10000 in a loop", None, (0,))
    t0 = time.perf_counter()
    subprocess.run(
        [sys.executable, "-m", "orchestrator.cli", "validate", "pick_place"],
        check=True,
        capture_output=True,
    )
    startup = time.perf_counter() - t0
    print(hostile.line("hostile classes"))
    print(mutated.line("mutated files"))
    print(invocations.line("bad invocations"))
    print(f"one `orchestrator validate pick_place` process, start-up included: {startup:.2f} s")
    for tally in (hostile, mutated, invocations):
        for problem in tally.tracebacks + tally.bad_exit + tally.bad_position:
            print("  PROBLEM", problem)
    slowest = sorted(zip(hostile.wall, every_hostile(), strict=True), key=lambda p: -p[0])[:3]
    print("slowest hostile inputs:", ", ".join(f"{h.name} {t:.2f} s" for t, h in slowest))


if __name__ == "__main__":
    main()
