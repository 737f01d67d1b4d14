"""Live sessions end to end: `orchestrator serve` in a subprocess, driven over Zenoh on
127.0.0.1 by `orchestrator send` and the Python client."""

from __future__ import annotations

import json
import socket
import subprocess
import sys
import time
from collections.abc import Iterator

import numpy as np
import pytest

from orchestrator.live.client import Client

from .cli_runner import invoke
from .conftest import CliResult


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


class Served:
    """A `serve` subprocess and the means to talk to it."""

    def __init__(self, name: str, *args: str) -> None:
        self.name = name
        self.endpoint = f"tcp/127.0.0.1:{_free_port()}"
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "orchestrator.cli", "serve", "pick_place", "--session", name,
             "--seed", "3", "--listen", self.endpoint, *args],
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        )  # fmt: skip
        self.client = Client(name, [self.endpoint], name="test", find_s=60.0)  # owns its tasks
        self.client.status()  # waits for the session to come up

    def send(self, *args: str, process: bool = False) -> CliResult:
        """`orchestrator send` to this session: in this process (the command's code, as the
        console runs it; a Python of its own costs ~0.7 s CPU a call), or with `process` in
        a subprocess, as a user runs it."""
        argv = ["send", self.name, *args, "--connect", self.endpoint]
        if not process:
            res = invoke(argv)
            return CliResult(res.exit_code, res.stdout, res.stderr)
        proc = subprocess.run(
            [sys.executable, "-m", "orchestrator.cli", *argv],
            capture_output=True, text=True, timeout=300, check=False,
        )  # fmt: skip
        return CliResult(proc.returncode, proc.stdout, proc.stderr)

    def status(self) -> dict:
        return self.client.status()

    def wait_state(self, state: str, timeout: float = 60.0) -> dict:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            status = self.status()
            if status["state"] == state:
                return status
            time.sleep(0.02)
        raise AssertionError(f"state {self.status()['state']}, never {state}")

    def wait_sim_time(self, seconds: float, timeout: float = 120.0) -> dict:
        """The status once the session's simulated time has advanced `seconds` [s]: a wait
        in wall time would see a session slowed by a loaded machine not got that far."""
        t0 = self.status()["sim_time"]
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            status = self.status()
            if status["sim_time"] >= t0 + seconds:
                return status
            time.sleep(0.02)
        raise AssertionError(f"simulated time stuck at {self.status()['sim_time']} s")

    def close(self) -> None:
        try:
            self.client.shutdown()
            self.proc.wait(timeout=30)
        finally:
            self.client.close()
            if self.proc.poll() is None:
                self.proc.kill()
                self.proc.wait()


@pytest.fixture(scope="module")
def served() -> Iterator[Served]:
    # paced at real time: a task lasts its simulated seconds in wall time at least, so a test
    # that sees MOVING and then pauses or e-stops finds the task still running on a loaded
    # machine (at `--speed 0` a reach could end between the status poll and the command)
    s = Served("t", "--speed", "1")
    yield s
    s.close()


def test_send_runs_a_pick_and_prints_its_result(served):
    res = served.send("run", "pick_place", "--wait", "--json", process=True)
    assert res.exit_code == 0, res.stderr
    result = json.loads(res.stdout)
    assert result["outcome"] == "succeeded" and result["success"]["cube_on_target"]
    assert served.status()["state"] == "IDLE"


@pytest.mark.parametrize(
    ("sets", "words"),
    [
        ("target=[1.4, 0.0, 0.5]", "outside the workspace"),
        ("target=[0.5, 0.2, 0.1]", "outside the workspace"),
        ("target=[0.5, 0.2, .nan]", "not finite"),
        ("target=[0.9, 0.55, 0.16]", "unreachable"),
    ],
)
def test_a_goal_outside_the_guardrails_is_refused_and_nothing_moves(served, sets, words):
    before = np.asarray(served.status()["tcp"])
    res = served.send("run", "reach", "--set", sets)
    assert res.exit_code == 2 and words in res.stderr, res.stderr
    time.sleep(0.2)
    status = served.status()
    assert status["state"] == "IDLE" and status["task"] is None
    assert np.linalg.norm(np.asarray(status["tcp"]) - before) < 2e-4  # held, not moved


def test_an_unknown_command_or_machine_exits_2(served):
    assert served.send("jump").exit_code == 2
    res = served.send("run", "no_such_machine")
    assert res.exit_code == 2 and "no_such_machine" in res.stderr


def test_estop_stops_a_running_task_until_reset(served):
    reply, _ = served.client.run("reach", ["target=[0.45, -0.25, 0.55]"])
    assert reply.accepted
    served.wait_state("MOVING")
    assert served.client.estop().accepted  # at once: `send` would start a Python first
    status = served.wait_state("ESTOPPED")
    deadline = time.monotonic() + 30
    while (status["last_result"] or {}).get("task") != reply.task:
        assert time.monotonic() < deadline
        time.sleep(0.05)
        status = served.status()
    result = status["last_result"]
    assert result["outcome"] == "aborted" and result["reason"]["guard"] == "estop"
    assert result["metrics"]["stop_time_s"] <= 0.15
    assert status["last_estop"]["ticks"] <= 1  # within one control tick of its arrival
    refused = served.send("run", "home")
    assert refused.exit_code == 2 and "reset" in refused.stderr
    assert served.send("reset").exit_code == 0
    served.wait_state("IDLE")
    assert served.send("reset").exit_code == 2  # nothing left to reset


def test_pause_holds_a_task_and_resume_lets_it_succeed(served):
    reply, _ = served.client.run("reach", ["target=[0.55, 0.2, 0.45]"])
    served.wait_state("MOVING")
    assert served.client.pause().accepted
    served.wait_state("PAUSED")
    served.wait_sim_time(0.5)  # the hold: the ramp down has long ended (simulated time)
    a = np.asarray(served.status()["tcp"])
    status = served.wait_sim_time(0.5)
    assert status["state"] == "PAUSED" and status["task"]["id"] == reply.task
    assert np.linalg.norm(np.asarray(status["tcp"]) - a) < 1e-3  # held within 1 mm
    res = served.send("resume")
    assert res.exit_code == 0
    deadline = time.monotonic() + 60
    while (served.status()["last_result"] or {}).get("task") != reply.task:
        assert time.monotonic() < deadline
        time.sleep(0.05)
    result = served.status()["last_result"]
    assert result["outcome"] == "succeeded"
    assert [e["event"] for e in result["metrics"]["events"]] == ["pause", "resume"]


def test_pause_without_a_task_is_refused(served):
    res = served.send("pause")
    assert res.exit_code == 2 and "no task is running" in res.stderr


def test_a_silent_client_trips_the_watchdog():
    # a watchdog of 1 s: a loaded machine may hold the heartbeat thread for a few tenths of a
    # second; the pick (~3.3 s simulated, paced at real time) outlasts the 1.2 s + 1 s here
    s = Served("w", "--speed", "1", "--watchdog", "1")
    try:
        with Client("w", [s.endpoint], heartbeat_s=0.05, name="planner") as alive:
            reply, _ = alive.run("pick_place")
            assert reply.accepted
            s.wait_state("MOVING")
            time.sleep(1.2)  # heartbeats flow: no trip
            assert s.status()["state"] in ("MOVING", "GRASPING")
            alive.stop_heartbeats()
            status = s.wait_state("ERROR", timeout=10)
        assert "watchdog" in status["error"]
        deadline = time.monotonic() + 30
        while (s.status()["last_result"] or {}).get("task") != reply.task:
            assert time.monotonic() < deadline
            time.sleep(0.05)
        result = s.status()["last_result"]
        assert result["outcome"] == "aborted" and result["reason"]["guard"] == "watchdog"
        assert s.send("run", "home").exit_code == 2
        assert s.send("reset").exit_code == 0
        assert s.send("run", "home", "--wait").exit_code == 0
    finally:
        s.close()


def test_send_to_no_session_says_so():
    port = _free_port()
    proc = subprocess.run(
        [sys.executable, "-c",
         "from orchestrator.live.client import Client, LiveError\n"
         f"c = Client('nobody', ['tcp/127.0.0.1:{port}'], heartbeat_s=None, find_s=0.5)\n"
         "try:\n    c.status()\nexcept LiveError as e:\n    print(e)\nc.close()"],
        capture_output=True, text=True, timeout=120, check=False,
    )  # fmt: skip
    assert "no session 'nobody' answered" in proc.stdout, proc.stderr


def test_watch_shows_the_state_and_says_when_heartbeats_are_lost(served):
    def watch(name: str, endpoint: str) -> subprocess.CompletedProcess:
        return subprocess.run(
            [sys.executable, "-m", "orchestrator.cli", "watch", name, "--for", "1.5",
             "--connect", endpoint],
            capture_output=True, text=True, timeout=120, check=False,
        )  # fmt: skip

    live = watch(served.name, served.endpoint)
    assert live.returncode == 0 and "IDLE" in live.stdout and "LOST" not in live.stdout
    gone = watch("nobody", f"tcp/127.0.0.1:{_free_port()}")
    assert gone.returncode == 1 and "LOST" in gone.stdout


def test_send_status_prints_the_status_json(served):
    res = served.send("status", "--json")
    assert res.exit_code == 0
    status = json.loads(res.stdout)["status"]
    assert status["session"] == "t" and status["scene"] == {"objects": ["cube"], "markers": ["pad"]}


def test_a_conveyor_runs_in_a_live_session_and_stops_its_parcel_at_the_barrier():
    from orchestrator.live.session import Session

    session = Session("sorting_conveyor", "belt-test", speed=0.0)
    belt = session.world.conveyor
    assert belt is not None
    for _ in range(800):  # 8 s: the first parcel is fed and carried to the beam
        session._tick()
        if belt.blocked and not belt.running:
            break
    assert belt.fed >= 1 and belt.blocked and not belt.running, (belt.fed, belt.blocked)
    for _ in range(20):  # the stopped belt holds what it carries
        session._tick()
    qvel = session.world.data.qvel
    carried = [belt.slots[i] for i in belt._on_belt]
    assert carried
    for h in carried:
        assert float(np.linalg.norm(qvel[h.qvel_adr : h.qvel_adr + 3])) < 0.01, h.name


VIA_MACHINE = """name: via_only
initial: MOVE
blackboard:
  waypoint: {type: vec3, default: [0.45, 0.0, 0.35], description: "Passed on the way [m]."}
states:
  MOVE:
    skill: move
    with: {target: [0.5, 0.1, 0.3], via: [{target: $waypoint}]}
    transitions: {reached: DONE, unreachable: FAILED, timeout: FAILED}
  DONE: {final: succeeded}
  FAILED: {final: failed}
"""


def test_a_goal_read_only_by_a_via_point_is_guarded(tmp_path):
    from orchestrator.language.load import load_scenario
    from orchestrator.language.scenario_checks import goal_keys
    from orchestrator.live.guardrail import GoalRejected, check_goals
    from orchestrator.world import World

    (tmp_path / "m.yaml").write_text(VIA_MACHINE)
    scenario = tmp_path / "s.yaml"
    scenario.write_text(
        "name: s\nmachine: m.yaml\nguards: [{workspace: {min: [0.2, -0.5, 0.0], max: [0.8, 0.5,"
        " 0.8]}}]\nscene:\n  objects:\n    - {name: cube, size: [0.05, 0.05, 0.05], xy: [0.5,"
        " 0.0]}\n"
    )
    assert goal_keys(load_scenario(str(scenario)).machine) == {"waypoint"}
    loaded = load_scenario(str(scenario), ["waypoint=[1.5, 0.0, 0.3]"])
    world = World.build(loaded.scenario, 0)
    with pytest.raises(GoalRejected, match=r"waypoint = \[1\.5, 0\.0, 0\.3\]: MOVE\.via\[0\]"):
        check_goals(loaded, ["waypoint"], world, world.home[: world.robot.n_arm])
