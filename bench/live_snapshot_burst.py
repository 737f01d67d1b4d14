"""An e-stop behind a burst of `snapshot` commands (issue 39): how long its effect waits, and
whether the arm then stays still.

A `serve pick_place --speed 1` subprocess on 127.0.0.1; per trial: a pick runs; `--burst`
snapshot commands are sent at once (not waiting for the replies); `--lag` ms later an e-stop
on its key. Measured: the e-stop's latency as the session measures it (`last_estop`: control
ticks started and wall ms from arrival to effect), the largest wall gap between two of the
session's heartbeats during the burst (a stalled loop shows here), the arm's peak joint speed
on every physics step from 0.2 s after the stop (the status's `arm_speed` windows), and the
wall time until every snapshot of the burst is written. Then `reset`, and the next trial.

    python bench/live_snapshot_burst.py [--trials 5] [--burst 30] [--lag 10] [--json PATH]
"""

from __future__ import annotations

import argparse
import json
import statistics
import time
from pathlib import Path
from typing import Any

from live_feed import LiveBench, emit

from orchestrator.live.protocol import Command, key
from tests.live_attacks import wait_for
from tests.live_server import SETTLE_S, motion_while_latched


def trial(bench: LiveBench, n: int, burst: int, lag_ms: float) -> dict:
    served, z = bench.served, bench.z
    c = served.client
    reply, _ = c.run()
    assert reply.accepted, reply.reason
    wait_for(lambda: c.status()["state"] in ("MOVING", "GRASPING"), 60.0)
    time.sleep(0.3)
    bench.clear()
    answers: list[dict] = []

    def collect(reply: Any) -> None:
        if reply.ok is not None:
            answers.append(json.loads(reply.ok.payload.to_string()))

    t0 = time.perf_counter()
    for i in range(burst):
        cmd = Command(op="snapshot", snapshot=f"t{n}-b{i}", client="burst")
        z.get(key(served.name, "command"), collect, payload=cmd.model_dump_json())
    time.sleep(lag_ms / 1000.0)
    assert c.estop().accepted
    status = wait_for(lambda: (s := c.status())["state"] == "ESTOPPED" and s, 10.0)
    stop_t = status["last_estop"]["t"]
    wait_for(lambda: len([e for e in bench.feed()[0] if e["event"].startswith("snapshot")])
             >= burst, 300.0)  # fmt: skip
    written_s = time.perf_counter() - t0
    time.sleep(SETTLE_S + 1.0)  # a second latched, watched
    events, statuses, beats = bench.feed()
    latched = [s for s in statuses if s["state"] == "ESTOPPED"]
    moving = motion_while_latched(latched, stop_t)
    windows = [s["arm_speed"] for s in latched if s["arm_speed"]["t0"] is not None]
    peaks = [w["peak"] for w in windows if w["t0"] >= stop_t + SETTLE_S]
    gaps = [b - a for a, b in zip(beats, beats[1:], strict=False)]
    ok = sum(1 for a in answers if a.get("accepted"))
    assert c.reset().accepted
    wait_for(lambda: c.status()["state"] == "IDLE", 60.0)
    return {
        "estop_ticks": status["last_estop"]["ticks"],
        "estop_ms": status["last_estop"]["ms"],
        "snapshots_accepted": ok,
        "snapshots_written": sum(1 for e in events if e["event"] == "snapshot"),
        "burst_written_s": round(written_s, 3),
        "heartbeat_gap_max_ms": round(1000 * max(gaps), 1) if gaps else None,
        "arm_peak_after_settle_rad_s": max(peaks) if peaks else None,
        "windows_moving_while_latched": len(moving),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--trials", type=int, default=5)
    ap.add_argument("--burst", type=int, default=30)
    ap.add_argument("--lag", type=float, default=10.0, help="ms from the burst to the e-stop")
    ap.add_argument("--json", type=Path)
    args = ap.parse_args()
    bench = LiveBench("burst", "--snapshot-count", str(args.trials * args.burst + 10))
    try:
        rows = [trial(bench, n, args.burst, args.lag) for n in range(args.trials)]
    finally:
        bench.close()
    ms = [r["estop_ms"] for r in rows]
    out = {
        "trials": args.trials, "burst": args.burst, "lag_ms": args.lag,
        "estop_ticks_max": max(r["estop_ticks"] for r in rows),
        "estop_ms_median": round(statistics.median(ms), 2), "estop_ms_max": round(max(ms), 2),
        "heartbeat_gap_max_ms": max(r["heartbeat_gap_max_ms"] or 0 for r in rows),
        "arm_peak_after_settle_rad_s_max": max(r["arm_peak_after_settle_rad_s"] or 0
                                               for r in rows),
        "windows_moving_while_latched": sum(r["windows_moving_while_latched"] for r in rows),
        "burst_written_s_median": round(statistics.median(r["burst_written_s"] for r in rows), 2),
        "rows": rows,
    }  # fmt: skip
    emit(out, args.json)


if __name__ == "__main__":
    main()
