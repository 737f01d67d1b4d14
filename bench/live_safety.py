"""Live safety: what may move the arm, and the way out of BLOCKED — measured on the arm.

A session runs in this process behind a real `serve` on loopback (Zenoh), so every physics step
of its world can be read: a probe on its step loop records the arm's joint angles and the TCP
after every physics step (ground truth, not the log). Commands come from outside, through
`orchestrator send` and `orchestrator ask` subprocesses (the planner: a local chat-completions
server with canned replies).

* overrides: guard, physics, scene and robot values (and `machine=`, `parcels=`), over the
  channel and proposed by the planner: each must be refused. The arm's largest joint
  excursion [rad] and TCP excursion [mm] over every physics step from the first command to
  0.5 s after the last reply, against the same over a quiet interval before (no command),
  once the hold has settled.
* offsets and via points: a 5 m hover (not an input of pick_place; an input of a machine that
  declares it; `orchestrator run --set` on the command line), a `place_at` whose hover point
  leaves the workspace, a NaN target.
* recovery: the two stuck cases of issue 26 — the hand pushed onto the cube (`collision`) and
  the TCP left past the workspace box (`workspace`), each made by a task started in-process
  past the channel's rules. The status (BLOCKED, the guard), `send recover --wait` (outcome,
  simulated duration, guards active, the largest growth of the violated guard's excess over
  the least it had reached, per physics step, against its tolerance), `send run home --wait`.

    python bench/live_safety.py [--json]
"""

from __future__ import annotations

import argparse
import json
import os
import socket
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from orchestrator.language.load import load_scenario  # noqa: E402
from orchestrator.live.client import Client  # noqa: E402
from orchestrator.live.server import serve  # noqa: E402
from orchestrator.live.session import Session  # noqa: E402
from orchestrator.live.task import Task  # noqa: E402
from tests import canned_planner  # noqa: E402
from tests.canned_planner import CannedPlanner  # noqa: E402

OVERRIDES = [
    "guards={}",
    "guards.workspace.max=[0.95, 0.7, 1.2]",
    "guards.contact_force.max_n=1000",
    "physics.safe_stop.max_decel_rad_s2=1",
    "physics.time_limit_s=86400",
    "scene.table.height=0.1",
    "scene.objects.cube.xy=[0.6, 0.3]",
    "robot.base_pos=[0, 0, 0.1]",
    "machine=reach",
    "parcels=3",
]
SETTLE_S = 3.0
"""Wall time the session holds before anything is measured [s]."""
QUIET_S = 20.0
"""The quiet interval the attacked one is compared with: no command at all [s]."""
HOVER_MACHINE = """name: hover
initial: UP
blackboard:
  hover: {type: vec3, default: [0, 0, 0.1], input: true}
states:
  UP:
    skill: move
    with: {target: pad, offset: $hover}
    transitions: {reached: DONE, unreachable: DONE, timeout: DONE}
  DONE: {final: succeeded}
"""


class Probe:
    """The arm's joint angles and TCP after every physics step, from a reference pose."""

    def __init__(self, session: Session) -> None:
        self.world = session.world
        self.lock = threading.Lock()
        self.reset()
        self.excess_of = None  # a guard whose excess growth is followed (recovery)
        self.growth = 0.0
        original = session.loop.set_observers
        session.loop.set_observers = lambda obs: original([*obs, self])  # type: ignore[method-assign]
        original([self])

    def reset(self) -> None:
        with self.lock:
            d, w = self.world.data, self.world
            self.q0 = d.qpos[w.arm_qpos].copy()
            self.tcp0 = d.site_xpos[w.tcp_site].copy()
            self.max_rad = 0.0
            self.max_mm = 0.0
            self.steps = 0

    def follow(self, guard, ctx) -> None:
        excess = guard.excess(ctx)
        self.excess_of, self.mask = guard, excess > 0.0
        self.least, self.growth = excess.copy(), 0.0

    def on_step(self, ctx) -> None:
        d, w = self.world.data, self.world
        with self.lock:
            dq = float(np.abs(d.qpos[w.arm_qpos] - self.q0).max())
            dx = float(np.linalg.norm(d.site_xpos[w.tcp_site] - self.tcp0)) * 1000.0
            self.max_rad, self.max_mm = max(self.max_rad, dq), max(self.max_mm, dx)
            self.steps += 1
            if self.excess_of is not None:
                e = self.excess_of.excess(ctx)
                grown = (e - self.least)[self.mask]
                self.growth = max(self.growth, float(grown.max(initial=0.0)))
                np.minimum(self.least, e, out=self.least)


def _port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _cli(*args: str, env: dict | None = None) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "orchestrator.cli", *args],
        capture_output=True, text=True, timeout=300, check=False, env=env,
    )  # fmt: skip


def overrides(endpoint: str, probe: Probe, planner_url: str) -> dict:
    """Every scenario value over the channel and from the planner: refused, the arm still."""
    send = ("send", "bench", "run", "reach", "--connect", endpoint)
    env = {**os.environ, "ORCHESTRATOR_PLANNER_URL": planner_url}
    rows, refused = [], 0
    time.sleep(SETTLE_S)  # the hold settles after the session starts
    probe.reset()
    time.sleep(QUIET_S)
    quiet = {"s": QUIET_S, "steps": probe.steps, "max_joint_rad": probe.max_rad,
             "max_tcp_mm": probe.max_mm}  # fmt: skip
    probe.reset()
    t0 = time.monotonic()
    for value in OVERRIDES:
        res = _cli(*send, "--set", "target=[0.5, 0.1, 0.4]", "--set", value)
        ok = res.returncode == 2 and "is a scenario value, not an input" in res.stderr
        key, _, raw = value.partition("=")
        CannedPlanner.reply = json.dumps(
            {"machine": "reach", "set": {"target": [0.5, 0.1, 0.4], key: json.loads(_yaml(raw))}}
        )
        asked = _cli("ask", "bench", "move the arm", "--connect", endpoint, env=env)
        ok_ask = asked.returncode == 2 and "is a scenario value, not an input" in asked.stderr
        refused += ok + ok_ask
        rows.append({"value": value, "channel_refused": ok, "planner_refused": ok_ask})
    time.sleep(0.5)
    attacked = {"s": round(time.monotonic() - t0, 2), "steps": probe.steps,
                "max_joint_rad": probe.max_rad, "max_tcp_mm": probe.max_mm}  # fmt: skip
    return {"rows": rows, "refused": refused, "sent": 2 * len(OVERRIDES),
            "attacked": attacked, "quiet": quiet}  # fmt: skip


def _yaml(raw: str) -> str:
    """The override values above as JSON (they are YAML flow values: `{}`, numbers, lists)."""
    return raw if raw[:1] in "[{" or raw.replace(".", "", 1).isdigit() else json.dumps(raw)


def positions(endpoint: str, session: Session) -> dict:
    """Offsets, via points and NaN: each refused with its reason."""
    out = {}
    res = _cli("send", "bench", "run", "pick_place", "--set", "hover=[0, 0, 5]", "--connect",
               endpoint)  # fmt: skip
    out["hover over the channel (not an input)"] = res.stderr.strip()
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "hover.yaml"
        path.write_text(HOVER_MACHINE)
        session.allow_paths = (Path(tmp),)
        res = _cli("send", "bench", "run", str(path), "--set", "hover=[0, 0, 5]", "--connect",
                   endpoint)  # fmt: skip
        out["hover over the channel (an input)"] = res.stderr.strip()
        session.allow_paths = ()
    res = _cli("run", "pick_place", "--set", "hover=[0, 0, 5]")
    out["hover on orchestrator run"] = res.stderr.strip().splitlines()[0]
    res = _cli("send", "bench", "run", "pick_place", "--set", "place_at=[0.5, 0.2, 1.15]",
               "--connect", endpoint)  # fmt: skip
    out["via point out of the workspace"] = res.stderr.strip()
    res = _cli("send", "bench", "run", "reach", "--set", "target=[.nan, 0, 0.4]", "--connect",
               endpoint)  # fmt: skip
    out["NaN target"] = res.stderr.strip()
    return out


def recovery(endpoint: str, session: Session, probe: Probe, client: Client, case: str) -> dict:
    """Make the stuck case in-process, then get out over the channel."""
    cube = session.ctx.object_pose("cube").pos
    if case == "hand on the cube":
        sets = ["guards={}", f"target=[{cube[0]}, {cube[1]}, 0.21]"]
    else:
        sets = ["guards.workspace.max=[0.95, 0.7, 1.2]", "target=[0.35, 0.62, 0.4]"]
    task = Task(900 + len(case), load_scenario("pick_place", sets, machine="reach"),
                session.ctx, "reach", session.loop)  # fmt: skip
    session.tasks.append(task)  # past the channel's rules, as an abort would leave it
    deadline = time.monotonic() + 120
    while (session.last_result or {}).get("task") != task.id or session.task is not None:
        assert time.monotonic() < deadline, "the stuck case did not end"
        time.sleep(0.05)
    time.sleep(0.3)
    status = client.status()
    blocked = status["blocked"]
    refused = _cli("send", "bench", "run", "home", "--connect", endpoint).stderr.strip()
    guard = next(g for g in session.blocked.guards if g.name == blocked["guard"])
    probe.follow(guard, session.ctx)
    res = _cli("send", "bench", "recover", "--wait", "--json", "--connect", endpoint)
    result = json.loads(res.stdout)
    probe.excess_of = None
    home = _cli("send", "bench", "run", "home", "--wait", "--json", "--connect", endpoint)
    return {
        "state": status["state"],
        "blocked": {k: blocked[k] for k in ("guard", "message", "recoverable")},
        "home refused": refused,
        "recover": result["outcome"],
        "recover_s": result["sim_time"],
        "transitions": [t["to"] for t in result["transitions"]],
        "excess_growth": round(probe.growth, 6),
        "tolerance": guard.ease_tolerance,
        "unit": guard.ease_unit,
        "home": json.loads(home.stdout)["outcome"],
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", action="store_true", help="print the figures as JSON")
    args = parser.parse_args()
    endpoint = f"tcp/127.0.0.1:{_port()}"
    session = Session("pick_place", "bench", seed=3, speed=1.0)
    probe = Probe(session)
    stop = threading.Event()
    thread = threading.Thread(target=serve, args=(session, [endpoint], None, None, stop))
    thread.start()
    planner_url, http = canned_planner.start()
    out: dict = {"load": os.getloadavg()}
    try:
        with Client("bench", [endpoint], find_s=60.0, name="bench") as client:
            client.status()
            out["overrides"] = overrides(endpoint, probe, planner_url)
            out["positions"] = positions(endpoint, session)
            out["recovery"] = {
                case: recovery(endpoint, session, probe, client, case)
                for case in ("hand on the cube", "TCP outside the workspace")
            }
    finally:
        stop.set()
        thread.join(30)
        http.shutdown()
    if args.json:
        print(json.dumps(out, indent=1))
        return
    o = out["overrides"]
    print(f"load {out['load'][0]:.1f}")
    print(f"overrides refused: {o['refused']} of {o['sent']} (channel and planner)")
    for what in ("quiet", "attacked"):
        a = o[what]
        print(f"  arm while {what} ({a['s']} s, {a['steps']} physics steps): max joint "
              f"{a['max_joint_rad']:.2e} rad, max TCP {a['max_tcp_mm']:.4f} mm")  # fmt: skip
    for what, line in out["positions"].items():
        print(f"{what}: {line}")
    for case, r in out["recovery"].items():
        print(f"{case}: {r['state']} by {r['blocked']['guard']} ({r['blocked']['message']}); "
              f"recover {r['recover']} in {r['recover_s']} s {r['transitions']}; excess grew "
              f"at most {r['excess_growth']} {r['unit']} (tolerance {r['tolerance']}); home "
              f"{r['home']}")  # fmt: skip


if __name__ == "__main__":
    main()
