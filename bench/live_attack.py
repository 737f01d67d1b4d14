"""The live channel under attack (issue 26): figures for BENCHMARKS.md, against real sessions
on 127.0.0.1.

* malformed: `orchestrator serve` (a subprocess); `--payloads` malformed payloads (random
  bytes, invalid UTF-8, truncated, deep, huge up to 1 MB plus two of 50 MB, binary, duplicate
  keys, wrong shapes) on the command key, each followed by a `status` there: refusals by
  category, anything accepted or unanswered, statuses answered; then one payload over
  Zenoh's message limit (64 MiB: dropped unanswered by the transport) and a status.
* estop (busy): the same kind of session at `--speed 1` running a pick while a flood of
  `--estop-flood` commands is in flight; `--estops` e-stops at random moments on the e-stop
  key: control ticks from arrival to effect (the session's `last_estop`), wall ms from
  arrival to effect, and the client's wall ms from sending to the reply (behind the flood
  on the same link).
* estop (wedged): a session served from this process (real Zenoh, loopback) whose command
  handler is wedged on purpose (a `pause` that never returns, commands queued behind it);
  a pick runs; an e-stop on its key: ticks from arrival to effect, and the arm's joint speeds
  read from MuJoCo after every physics step (500 Hz) from the e-stop's effect until rest:
  peak speed, time until every joint is under 0.01 rad/s, and the peak after that (held).
* flood: `--flood` commands sent without waiting (status, run, pause, malformed) to a
  `serve` subprocess: every one answered or refused, the server's RSS and thread count
  before and after.
* kill: `send --wait` waits on a task; the server is SIGKILLed: the client's exit code and
  time to exit; the server restarted on the same port and name: its epoch, and that no task
  id of the first life comes back.
* bystander: a task's owner falls silent while another client keeps beating: when the
  watchdog (serve's default, 1 s) trips.

    python bench/live_attack.py [--payloads 1200] [--flood 10000] [--estops 10] [--json PATH]
"""

from __future__ import annotations

import argparse
import json
import os
import random
import statistics
import sys
import threading
import time
from pathlib import Path
from typing import Any

import numpy as np

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from orchestrator.live.access import MAX_MESSAGE_BYTES  # noqa: E402
from orchestrator.live.client import Client  # noqa: E402
from orchestrator.live.protocol import key  # noqa: E402
from orchestrator.live.server import serve  # noqa: E402
from orchestrator.live.session import Session  # noqa: E402
from tests.live_attacks import (  # noqa: E402
    Served,
    attack_malformed,
    bystander,
    flood,
    free_port,
    hold_paused_task,
    kill_mid_wait,
    malformed_payloads,
    wait_for,
)

REST_RAD_S = 0.01
"""Every arm joint slower than this: the arm is at rest [rad/s]."""
FAST_RAD_S = 0.5
"""The wedged e-stop is sent once some arm joint moves this fast [rad/s]."""


def malformed_figures(n: int) -> dict[str, Any]:
    served = Served("attack-malformed", "--watchdog", "0")
    try:
        payloads = malformed_payloads(n, seed=0)
        payloads += [("huge", b'{"op": "status", "client": "' + b"x" * 50_000_000 + b'"}')] * 2
        z = served.raw()
        rss0 = served.rss_mb()
        t0 = time.perf_counter()
        tally = attack_malformed(z, served.name, payloads)
        wall = time.perf_counter() - t0
        # over Zenoh's message limit: dropped by the transport, unanswered; the link and the
        # session go on
        over = attack_malformed(z, served.name, [("over the limit", b"x" * (MAX_MESSAGE_BYTES
                                                                         + 1))])  # fmt: skip
        z.close()
        state = served.client.status()["state"]
        return {
            "payloads": tally.sent,
            "refused": tally.refused,
            "accepted": tally.accepted,
            "unanswered": tally.unanswered,
            "status_answered": tally.status_answered,
            "by_category": dict(tally.by_category),
            "reasons": dict(tally.reasons.most_common(12)),
            "over_zenoh_limit": {
                "bytes": MAX_MESSAGE_BYTES + 1,
                "unanswered": over.unanswered,
                "status_answered_after": over.status_answered,
            },
            "state_after": state,
            "wall_s": round(wall, 2),
            "rss_mb": [round(rss0, 1), round(served.rss_mb(), 1)],
        }
    finally:
        served.close()


def estop_busy_figures(n: int, flood_n: int) -> dict[str, Any]:
    served = Served("attack-estop", "--speed", "1", "--watchdog", "0")
    rng = random.Random(0)
    ticks, ms, stops, answered = [], [], [], []
    try:
        z = served.raw()
        c = served.client
        for _ in range(n):
            reply, _ = c.run("pick_place")
            assert reply.accepted, reply.reason
            wait_for(lambda: c.status()["state"] in ("MOVING", "GRASPING"), 60.0)
            time.sleep(rng.uniform(0.2, 3.0))
            cmd_key = key(served.name, "command")
            handles = [z.get(cmd_key, payload=b'{"op": "status"}', timeout=60)
                       for _ in range(flood_n)]  # fmt: skip
            t0 = time.perf_counter()
            assert c.estop().accepted
            answered.append((time.perf_counter() - t0) * 1000.0)
            status = wait_for(
                lambda t=reply.task: (s := c.status())["last_result"]
                and s["last_result"]["task"] == t and s, 120.0,
            )  # fmt: skip
            for h in handles:
                list(h)
            ticks.append(status["last_estop"]["ticks"])
            ms.append(status["last_estop"]["ms"])
            stops.append(status["last_result"]["metrics"].get("stop_time_s"))
            assert c.reset().accepted
            wait_for(lambda: c.status()["state"] == "IDLE", 30.0)
        z.close()
    finally:
        served.close()
    return {"estops": n, "flood_in_flight": flood_n, "ticks_max": max(ticks),
            "ticks": ticks, "ms_median": round(statistics.median(ms), 2),
            "ms_max": round(max(ms), 2), "stop_time_s_max": max(s for s in stops if s),
            "reply_ms_median": round(statistics.median(answered), 2),
            "reply_ms_max": round(max(answered), 2)}  # fmt: skip


class JointSpeeds:
    """Records the arm's joint speeds after every physics step (MuJoCo's ground truth)."""

    def __init__(self) -> None:
        self.t: list[float] = []
        self.speed: list[float] = []

    def on_start(self, ctx: Any, executor: Any) -> None:
        self.dof = ctx.world.arm_dof
        self.qvel = ctx.world.data.qvel

    def on_tick(self, ctx: Any, executor: Any) -> None:
        pass

    def on_step(self, ctx: Any) -> None:
        self.t.append(ctx.t)
        self.speed.append(float(np.max(np.abs(self.qvel[self.dof]))))

    def on_end(self, ctx: Any, executor: Any, result: Any) -> None:
        pass


def estop_wedged_figures() -> dict[str, Any]:
    probes: list[JointSpeeds] = []

    def recorder(task: Any) -> JointSpeeds:
        probes.append(JointSpeeds())
        return probes[-1]

    session = Session("pick_place", "attack-wedged", seed=3, speed=1.0, recorder=recorder)
    wedge = threading.Event()
    real = session.submit

    def submit(cmd: Any) -> Any:
        if cmd.op == "pause":
            wedge.wait(120)
        return real(cmd)

    session.submit = submit  # type: ignore[method-assign]
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    stop = threading.Event()
    thread = threading.Thread(target=serve, args=(session, [endpoint]), kwargs={"stop": stop})
    thread.start()
    try:
        with Client(session.name, [endpoint], name="bench", find_s=30.0) as c:
            reply, _ = c.run("pick_place")
            assert reply.accepted, reply.reason
            cmd_key = key(session.name, "command")
            stuck = [c.z.get(cmd_key, payload=b'{"op": "pause"}', timeout=60)]
            time.sleep(0.05)  # the handler is wedged on it; more commands queue behind it
            stuck += [c.z.get(cmd_key, payload=b'{"op": "status"}', timeout=60) for _ in range(50)]
            wait_for(lambda: probes and probes[-1].speed and probes[-1].speed[-1] > FAST_RAD_S,
                     60.0, period=0.001)  # fmt: skip
            answered_while_wedged = sum(h.try_recv() is not None for h in stuck)
            t_estop = session.ctx.t
            c.estop()
            status = wait_for(
                lambda: (s := c.status())["last_result"]
                and s["last_result"]["task"] == reply.task and s, 60.0,
            )  # fmt: skip
            wedge.set()
            for h in stuck:
                list(h)
    finally:
        wedge.set()
        stop.set()
        thread.join(30)
    probe = probes[0]
    t = np.asarray(probe.t)
    speed = np.asarray(probe.speed)
    effect_t = status["last_estop"]["t"]
    after = t >= effect_t - 1e-9
    moving = np.nonzero(after & (speed >= REST_RAD_S))[0]
    rest = int(moving[-1]) + 1 if moving.size else int(np.argmax(after))  # under it for good
    return {
        "ticks": status["last_estop"]["ticks"],
        "ms": status["last_estop"]["ms"],
        "sim_t_arrival_approx": round(t_estop, 4),
        "sim_t_effect": effect_t,
        "outcome": status["last_result"]["outcome"],
        "reason": status["last_result"]["reason"]["guard"],
        "commands_answered_while_wedged": answered_while_wedged,
        "physics_steps_after_effect": int(after.sum()),
        "peak_joint_speed_at_effect_rad_s": round(float(speed[after][:5].max()), 4),
        "joint_speed_after_rad_s": {
            f"{ms} ms": round(float(speed[after][min(ms // 2, int(after.sum()) - 1)]), 4)
            for ms in (10, 20, 40, 80)
        },
        "below_0.01_rad_s_for_good_after_s": round(float(t[min(rest, len(t) - 1)] - effect_t), 4),
        "final_joint_speed_rad_s": round(float(speed[-1]), 5),
        "stop_time_s": status["last_result"]["metrics"].get("stop_time_s"),
        "stop_distance_mm": status["last_result"]["metrics"].get("stop_distance_mm"),
    }


def flood_figures(n: int, repeats: int = 3, window: int | None = None) -> dict[str, Any]:
    """RSS from a cold session (after one status), then with a pick running and paused (busy,
    frozen: see `hold_paused_task`) and a 1,000-command warm-up of the same mix, then after
    each of `repeats` floods of `n` (a leak grows with each); at most `window` commands in
    flight (None: all at once, most refused as overloaded)."""
    served = Served("attack-flood", "--watchdog", "0")
    try:
        z = served.raw()
        cold, threads0 = served.rss_mb(), served.threads()
        hold_paused_task(served)
        flood(z, served.name, 1000, seed=99)
        warm = served.rss_mb()
        t0 = time.perf_counter()
        counts = flood(z, served.name, n, window=window)
        wall = time.perf_counter() - t0
        after = [served.rss_mb()]
        threads1 = served.threads()
        unanswered = counts.get("unanswered", 0)
        for i in range(1, repeats):
            more = flood(z, served.name, n, seed=i, window=window)
            unanswered += more.get("unanswered", 0)
            after.append(served.rss_mb())
        z.close()
        return {
            "commands": n,
            "in_flight_max": window or n,
            "floods": repeats,
            "answered": sum(v for k, v in counts.items() if k != "unanswered"),
            "unanswered_all_floods": unanswered,
            "counts": dict(counts),
            "wall_s": round(wall, 2),
            "rss_mb_cold": round(cold, 1),
            "rss_mb_warm": round(warm, 1),
            "rss_mb_after_each_flood": [round(a, 1) for a in after],
            "rss_growth_mb_first_flood": round(after[0] - warm, 1),
            "rss_growth_mb_from_cold": round(after[0] - cold, 1),
            "threads": [threads0, threads1],
        }
    finally:
        served.close()


def kill_figures() -> dict[str, Any]:
    first = Served("attack-kill")
    epoch1 = first.client.status()["epoch"]
    ids1 = []
    for _ in range(2):
        reply, result = first.client.run("home", wait=True)
        ids1.append(reply.task)
    killed = kill_mid_wait(first)
    ids1.append(killed["task"])
    first.client.close()
    second = Served("attack-kill", port=first.port)  # same name, same port
    try:
        epoch2 = second.client.status()["epoch"]
        ids2 = [second.client.run("home", wait=True)[0].task for _ in range(3)]
    finally:
        second.close()
    return {**{k: v for k, v in killed.items() if k != "task"}, "epochs": [epoch1, epoch2],
            "ids_first_life": ids1, "ids_after_restart": ids2,
            "reused": sorted(set(ids1) & set(ids2))}  # fmt: skip


def bystander_figures() -> dict[str, Any]:
    served = Served("attack-bystander")
    try:
        return bystander(served)
    finally:
        served.close()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--payloads", type=int, default=1200)
    parser.add_argument("--flood", type=int, default=10_000)
    parser.add_argument("--estops", type=int, default=10)
    parser.add_argument("--estop-flood", type=int, default=2000)
    sections_all = ["malformed", "estop_busy", "estop_wedged", "flood", "flood_windowed",
                    "kill", "bystander"]  # fmt: skip
    parser.add_argument("--only", nargs="*", default=None, choices=sections_all)
    parser.add_argument("--json", type=Path, default=None)
    args = parser.parse_args()
    sections = {
        "malformed": lambda: malformed_figures(args.payloads),
        "estop_busy": lambda: estop_busy_figures(args.estops, args.estop_flood),
        "estop_wedged": estop_wedged_figures,
        "flood": lambda: flood_figures(args.flood),
        "flood_windowed": lambda: flood_figures(args.flood, window=200),
        "kill": kill_figures,
        "bystander": bystander_figures,
    }
    out: dict[str, Any] = {"load": os.getloadavg()}
    for name, run in sections.items():
        if args.only and name not in args.only:
            continue
        t0 = time.perf_counter()
        out[name] = run()
        print(f"{name} ({time.perf_counter() - t0:.0f} s): {json.dumps(out[name])}", flush=True)
    out["load_after"] = os.getloadavg()
    if args.json is not None:
        args.json.write_text(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
