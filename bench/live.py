"""Live sessions and events: the figures of docs/live.md, from one run.

* e-stop latency: a session (`orchestrator serve`, a subprocess) runs a pick at `--speed 1`;
  a client e-stops it over Zenoh on loopback `--estops` times (a task each time, at a random
  moment of it). Per e-stop: control ticks started between its arrival and its effect, and
  wall time [ms] from the command's arrival to the abort.
* command round trip: `status` commands from the Python client to an idle session, wall
  time from sending to the reply [ms]: median, p99, max over `--commands`.
* real time: at `--speed 1`, a pick runs while status is published at 10 Hz; the ratio of
  the task's simulated time to its wall time.
* pause / resume (no session): `run pick_place --seed 3` paused for 1 s at several moments;
  the delay over the uninterrupted run [s] and the TCP's drift while held [mm].

    python bench/live.py [--commands 1000] [--estops 10]
"""

from __future__ import annotations

import argparse
import json
import random
import socket
import statistics
import subprocess
import sys
import time

from orchestrator.engine.runner import run_episode
from orchestrator.language.load import load_scenario
from orchestrator.live.client import Client


def _port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _wait_result(client: Client, task: int, timeout: float = 120.0) -> dict:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        last = client.status().get("last_result") or {}
        if last.get("task") == task:
            return last
        time.sleep(0.05)
    raise RuntimeError(f"task {task} did not end")


def session_figures(n_commands: int, n_estops: int) -> dict:
    endpoint = f"tcp/127.0.0.1:{_port()}"
    proc = subprocess.Popen(
        [sys.executable, "-m", "orchestrator.cli", "serve", "pick_place", "--session", "bench",
         "--seed", "3", "--speed", "1", "--listen", endpoint],
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
    )  # fmt: skip
    out: dict = {}
    try:
        with Client("bench", [endpoint], find_s=120.0, name="bench") as c:
            c.status()
            rtt = []
            for _ in range(n_commands):
                t0 = time.perf_counter()
                c.command("status")
                rtt.append((time.perf_counter() - t0) * 1000.0)
            rtt.sort()
            out["round_trip_ms"] = {
                "n": len(rtt),
                "median": round(statistics.median(rtt), 3),
                "p99": round(rtt[int(0.99 * (len(rtt) - 1))], 3),
                "max": round(rtt[-1], 3),
            }
            reply, result = c.run("pick_place", wait=True)
            assert result is not None
            out["realtime"] = {
                "task_sim_s": result["sim_time"],
                "task_wall_s": result["wall_time"],
                "sim_over_wall": round(result["sim_time"] / result["wall_time"], 4),
            }
            rng = random.Random(0)
            latencies = []
            for i in range(n_estops):
                target = f"target=[{0.4 + 0.1 * (i % 3)}, {0.25 * (-1) ** i}, 0.5]"
                reply, _ = c.run("reach", [target])
                assert reply.accepted, reply.reason
                while c.status()["state"] != "MOVING":
                    time.sleep(0.005)
                time.sleep(rng.uniform(0.05, 0.4))
                c.estop()
                res = _wait_result(c, reply.task)  # type: ignore[arg-type]
                est = c.status()["last_estop"]
                latencies.append((est["ticks"], est["ms"], res["metrics"].get("stop_time_s")))
                c.reset()
            out["estop"] = {
                "n": len(latencies),
                "max_ticks": max(t for t, _, _ in latencies),
                "ms_median": round(statistics.median(ms for _, ms, _ in latencies), 3),
                "ms_max": round(max(ms for _, ms, _ in latencies), 3),
                "stop_time_s_max": max(s or 0.0 for _, _, s in latencies),
            }
            c.shutdown()
        proc.wait(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
    return out


def pause_figures() -> dict:
    base = run_episode(load_scenario("pick_place"), 3).sim_time
    rows = []
    for t in (0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0):
        r = run_episode(load_scenario("pick_place", events=[f"{t}:pause", f"{t + 1}:resume"]), 3)
        p = r.metrics["pauses"][0]
        delay = round(r.sim_time - base, 3)
        rows.append({"pause_at": t, "outcome": r.outcome, "delay_s": delay,
                     "drift_mm": p["drift_mm"]})  # fmt: skip
    return {"uninterrupted_sim_s": base, "rows": rows}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--commands", type=int, default=1000)
    ap.add_argument("--estops", type=int, default=10)
    args = ap.parse_args()
    figures = {"session": session_figures(args.commands, args.estops), "pause": pause_figures()}
    print(json.dumps(figures, indent=2))


if __name__ == "__main__":
    main()
