"""How long and how much memory each snapshot reader takes to refuse what is not a snapshot.

Each reader runs in a fresh process (`orchestrator snapshot show`, `orchestrator run --from`,
and a live session's restore loader `live.snapshots.read_session`) on:

* /dev/zero (endless),
* a 2 GB sparse file that starts like a snapshot (`ORCHESTRATOR-SNAPSHOT 2` then holes),
* a header nested 200,000 levels deep, and a 2 MiB header line without its end,
* a snapshot signed with this user's key whose header has every key of the wrong type.

Reported per reader and file: the exit status, the wall time and the process's peak RSS
(`wait4`), with the machine's load. The process's own start (Python, numpy, MuJoCo imports) is
measured alone first (the reader on a missing file) and reported beside. Then the readers'
own work, in this process after the imports: each reader function's wall time (median of 5)
and the memory it allocates at its peak (tracemalloc).

    python bench/snapshot_readers.py            # the table (markdown)
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

SNIPPET = (
    "import sys\n"
    "from pathlib import Path\n"
    "from orchestrator.engine.snapshot import SnapshotError\n"
    "from orchestrator.language.load import load_scenario\n"
    "from orchestrator.live.snapshots import read_session\n"
    "loaded = load_scenario('pick_place')\n"
    "try:\n"
    "    read_session(Path(sys.argv[1]), loaded)\n"
    "except SnapshotError as exc:\n"
    "    print(exc, file=sys.stderr)\n"
    "    sys.exit(2)\n"
)

READERS = {
    "snapshot show": [sys.executable, "-m", "orchestrator.cli", "snapshot", "show"],
    "run --from": [sys.executable, "-m", "orchestrator.cli", "run", "--from"],
    "live restore (read_session)": [sys.executable, "-c", SNIPPET],
}


def _files(folder: Path) -> dict[str, str]:
    sparse = folder / "huge.snap"
    with sparse.open("wb") as f:
        f.write(b"ORCHESTRATOR-SNAPSHOT 2\n")
        f.truncate(2 << 30)
    deep = folder / "deep.snap"
    deep.write_bytes(b"ORCHESTRATOR-SNAPSHOT 2\n" + b"[" * 200_000 + b"\n")
    endless = folder / "no_end.snap"
    endless.write_bytes(b"ORCHESTRATOR-SNAPSHOT 2\n" + b"{" * (2 << 20))
    typed = folder / "wrong_types.snap"
    from orchestrator.engine.snapshot.snapfile import write_snapshot

    write_snapshot(typed, {"kind": "run", "t": "soon", "break": 5, "versions": [1]}, b"")
    return {"missing file (start-up alone)": str(folder / "missing.snap"),
            "/dev/zero": "/dev/zero", "2 GB sparse file": str(sparse),
            "header nested 200,000 deep": str(deep), "2 MiB header without end": str(endless),
            "signed, wrong-typed header": str(typed)}  # fmt: skip


def _measure(argv: list[str]) -> tuple[int, float, float, str]:
    wall0 = time.perf_counter()
    proc = subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    assert proc.stderr is not None
    err = proc.stderr.read().decode(errors="replace")
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - wall0
    proc.returncode = os.waitstatus_to_exitcode(status)
    return proc.returncode, wall, usage.ru_maxrss / 1024, " ".join(err.split())[:90]


def main() -> int:
    folder = Path(tempfile.mkdtemp(prefix="snapshot-readers-"))
    os.environ["XDG_CONFIG_HOME"] = str(folder / "config")
    os.environ.pop("ORCHESTRATOR_SNAPSHOT_KEY", None)
    files = _files(folder)
    print(f"load average at start: {os.getloadavg()[0]:.1f} ({os.cpu_count()} cores)")
    print("\n| reader | file | exit | wall [s] | peak RSS [MB] | says |")
    print("|---|---|---|---|---|---|")
    worst = 0.0
    for reader, argv in READERS.items():
        for name, path in files.items():
            code, wall, rss, said = _measure([*argv, path])
            if name != "missing file (start-up alone)":
                worst = max(worst, wall)
            print(f"| {reader} | {name} | {code} | {wall:.2f} | {rss:.0f} | {said} |", flush=True)
    print(f"\nslowest refusal {worst:.2f} s wall (process start included)")
    _in_process(files)
    print(f"\nload average at end: {os.getloadavg()[0]:.1f}")
    return 0


def _in_process(files: dict[str, str]) -> None:
    import statistics
    import tracemalloc

    from orchestrator.engine.snapshot import SnapshotError, read_snapshot
    from orchestrator.engine.snapshot.run_snapshot import check_any_header, check_header
    from orchestrator.engine.snapshot.snapfile import read_header
    from orchestrator.language.load import load_scenario
    from orchestrator.live.snapshots import read_session

    loaded = load_scenario("pick_place")
    readers = {
        "show (read_header + check)": lambda p: check_any_header(p, read_header(p)),
        "run --from (read_snapshot + check_header)": lambda p: check_header(read_snapshot(p)),
        "live restore (read_session)": lambda p: read_session(p, loaded),
    }
    print(
        "\n| reader, in process | file | refused | wall [ms] (median of 5) | peak allocated [MB] |"
    )
    print("|---|---|---|---|---|")
    for reader, fn in readers.items():
        for name, path in files.items():
            walls, peak, refused = [], 0, True
            for _ in range(5):
                tracemalloc.start()
                wall0 = time.perf_counter()
                try:
                    fn(Path(path))
                    refused = False
                except SnapshotError:
                    pass
                walls.append(time.perf_counter() - wall0)
                peak = max(peak, tracemalloc.get_traced_memory()[1])
                tracemalloc.stop()
            print(
                f"| {reader} | {name} | {'yes' if refused else 'NO'} | "
                f"{statistics.median(walls) * 1e3:.1f} | {peak / 1e6:.1f} |",
                flush=True,
            )


if __name__ == "__main__":
    sys.exit(main())
