"""The restore race of issue 39, measured on the arm: does an e-stop hold when a `restore`
is in flight, and does the arm stay still?

A `serve pick_place --speed 1` subprocess on 127.0.0.1. Once: a pick runs, a snapshot of it
mid-motion is written, the task stopped. Per trial: a pick runs; one client sends `restore`
of that snapshot (the session reads it, ~0.1 s, before queuing it) and, `--lag` ms later,
another client e-stops on the e-stop key. Then 2 s with no `reset`. Measured from the
session's published status: whether every status stayed ESTOPPED, the arm's peak joint speed
on any physics step from 0.2 s after the stop (`arm_speed`), the TCP's displacement over the
same span [mm], and whether the restore landed in the window (refused when applied, after the
e-stop) or before it (applied, then stopped by the e-stop). Then `reset`, and the next trial.

    python bench/live_latch.py [--trials 5] [--lag 20] [--json PATH]
"""

from __future__ import annotations

import argparse
import threading
import time
from pathlib import Path
from typing import Any

import numpy as np
from live_feed import LiveBench, emit

from orchestrator.live.client import Client
from tests.live_attacks import wait_for
from tests.live_server import SETTLE_S, motion_while_latched


def _restore(client: Client, replies: dict[str, Any]) -> None:
    replies["r"] = client.command("restore", snapshot="mid")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--trials", type=int, default=5)
    ap.add_argument("--lag", type=float, default=20.0, help="ms from the restore to the e-stop")
    ap.add_argument("--json", type=Path)
    args = ap.parse_args()
    bench = LiveBench("latch")
    served = bench.served
    rows = []
    try:
        with Client("latch", [served.endpoint], name="guard") as guard:
            c = served.client
            assert c.run()[0].accepted
            wait_for(lambda: c.status()["state"] in ("MOVING", "GRASPING"), 60.0)
            time.sleep(0.5)
            assert c.command("snapshot", snapshot="mid").accepted
            wait_for(lambda: any(e["event"] == "snapshot" for e in bench.feed()[0]), 60.0)
            assert c.stop().accepted
            wait_for(lambda: c.status()["state"] == "IDLE", 60.0)
            for _ in range(args.trials):
                assert c.run()[0].accepted
                wait_for(lambda: c.status()["state"] in ("MOVING", "GRASPING"), 60.0)
                time.sleep(0.3)
                bench.clear()
                replies: dict[str, Any] = {}
                sender = threading.Thread(target=_restore, args=(c, replies))
                sender.start()
                time.sleep(args.lag / 1000.0)
                assert guard.estop().accepted
                sender.join(30.0)
                status = wait_for(lambda: (s := c.status())["state"] == "ESTOPPED" and s, 10.0)
                stop_t = status["last_estop"]["t"]
                time.sleep(2.0)
                events, statuses, _ = bench.feed()
                after = [s for s in statuses if (s.get("last_estop") or {}).get("t") == stop_t]
                settled = [s for s in after if s["sim_time"] >= stop_t + SETTLE_S]
                tcp = np.array([s["tcp"] for s in settled]) if settled else np.zeros((1, 3))
                names = [e["event"] for e in events]
                at = names.index("estop") if "estop" in names else len(names)
                refused = any(e["event"] == "refused" and e.get("op") == "restore"
                              for e in events[at:])  # fmt: skip
                rows.append({
                    "restore_answer": "accepted" if replies["r"].accepted else replies["r"].reason,
                    "restore_in_window": refused,
                    "restore_applied_after_estop": "restore" in names[at:],
                    "states_after": sorted({s["state"] for s in after}),
                    "arm_peak_after_settle_rad_s": max(  # windows from 0.2 s after the stop
                        (s["arm_speed"]["peak"] for s in after if s["arm_speed"]["t0"] is not None
                         and s["arm_speed"]["t0"] >= stop_t + SETTLE_S), default=None),
                    "moving_windows": len(motion_while_latched(after, stop_t)),
                    "tcp_displacement_mm": round(
                        1000 * float(np.linalg.norm(tcp - tcp[0], axis=1).max()), 3),
                    "estop_ticks": status["last_estop"]["ticks"],
                })  # fmt: skip
                assert c.reset().accepted
                wait_for(lambda: c.status()["state"] == "IDLE", 60.0)
    finally:
        bench.close()
    out = {
        "trials": args.trials, "lag_ms": args.lag,
        "latch_held": sum(r["states_after"] == ["ESTOPPED"] for r in rows),
        "restores_in_window": sum(r["restore_in_window"] for r in rows),
        "restores_applied_after_estop": sum(r["restore_applied_after_estop"] for r in rows),
        "arm_peak_after_settle_rad_s_max": max((r["arm_peak_after_settle_rad_s"] or 0)
                                               for r in rows),
        "tcp_displacement_mm_max": max(r["tcp_displacement_mm"] for r in rows),
        "rows": rows,
    }  # fmt: skip
    emit(out, args.json)


if __name__ == "__main__":
    main()
