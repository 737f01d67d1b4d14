"""How long does resuming a snapshot take, by replay (the default of `run --from`) and by
restoring its data (`load_run(..., restore=True)`), and does each end as the uninterrupted run?

For each scenario (seed 0) and each fraction of its run, a fresh episode runs to that tick,
the snapshot is written, and it is read back both ways and run to the end; the `run --json`
object minus the wall time is compared with the uninterrupted run's. Wall times: report them
with the machine's load (they are medians of `--repeat` reads).

    python bench/snapshot_restore.py --only sorting --fraction 0.9
    python bench/snapshot_restore.py                  # every bundled scenario at 1/3 and 2/3

Exit status 0 when every restored resume is identical (or was replayed, and is), 1 otherwise.
"""

from __future__ import annotations

import argparse
import os
import statistics
import tempfile
import time
from pathlib import Path

from orchestrator.engine.runner import drive, new_run
from orchestrator.engine.snapshot.identity import comparable
from orchestrator.engine.snapshot.run_snapshot import load_run, write_run
from orchestrator.engine.snapshot.stops import Stop, run_to
from orchestrator.language.bundled import bundled_names
from orchestrator.language.load import load_scenario


def _resume(path: Path, restore: bool, repeat: int) -> tuple[float, str, dict]:
    times, how, got = [], "", {}
    for _ in range(repeat):
        wall0 = time.perf_counter()
        snap = load_run(path, restore=restore)
        times.append(time.perf_counter() - wall0)
        how = snap.how
        result = drive(snap.run)
        assert result is not None
        got = comparable(result)
    return statistics.median(times), how, got


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", action="append", help="a scenario (repeatable)")
    parser.add_argument("--fraction", action="append", type=float, help="of the run's ticks")
    parser.add_argument("--repeat", type=int, default=1, help="reads per way (median)")
    args = parser.parse_args()
    names = args.only or list(bundled_names("scenarios"))
    fractions = args.fraction or [1 / 3, 2 / 3]
    os.environ.setdefault("XDG_CONFIG_HOME", tempfile.mkdtemp())
    print(f"load average {os.getloadavg()[0]:.1f}")
    print("| scenario | tick | replay [s] | restore [s] | ratio | replay identical | restore |")
    print("|---|---|---|---|---|---|---|")
    ok = True
    with tempfile.TemporaryDirectory() as folder:
        for name in names:
            loaded = load_scenario(name)
            full_run = new_run(loaded, 0)
            expected = comparable(drive(full_run))
            ticks = full_run.ctx.tick
            for fraction in fractions:
                tick = max(1, int(ticks * fraction))
                run = new_run(loaded, 0)
                stop = Stop(tick, False, f"control tick {tick}", "bench")
                if not run_to(run, stop):
                    continue
                path = Path(folder) / f"{name}-{tick}.snap"
                write_run(path, run, stop.header(), [])
                del run
                replay_s, _, replayed = _resume(path, False, args.repeat)
                restore_s, how, restored = _resume(path, True, args.repeat)
                same = restored == expected
                ok = ok and same
                what = "identical" if same else "DIFFERS"
                if how != "restored":
                    what += f" ({how[:60]})"
                ratio = replay_s / restore_s
                print(
                    f"| {name} | {tick} | {replay_s:.2f} | {restore_s:.2f} | {ratio:.1f}x | "
                    f"{replayed == expected} | {what} |"
                )
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(main())
