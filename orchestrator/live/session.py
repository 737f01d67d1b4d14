"""A live session: a world kept running, the robot idle and holding until a command arrives.

Commands come from any thread through `submit` (the Zenoh server's callbacks call it): it
answers at once, accepted or rejected with the reason, after checking what it can without
touching the world (a task's machine and `--set` values are loaded and validated, its goals
go through the guardrail). Accepted commands wait in an inbox that the session's loop drains
at the start of every control tick, highest priority first (`estop` > `stop`, `shutdown` >
`pause`, `resume`, `reset` > `run`, `recover`); tasks run one after another, first in first
out.

Only the task machine's inputs may be set (live/inputs.py): limits are the scenario's. While no
task runs, the guards every task starts with are checked on the idle world (live/blocked.py):
a violated one makes the state BLOCKED, and then only a recovery machine (`recover`) may start.
Every change of the published state is an `events` message (`{"event": "state", ...}`).

Simulated time is paced to the wall clock: `speed` 1 is real time, 2 twice as fast, 0 as
fast as the machine can (while a task runs; an idle or paused robot is kept at real time:
there is nothing to hurry and the CPU is left to others). A paused task's time limit stands
still with its clock. A watchdog, when set, expects a client's
heartbeat at least every `watchdog_s` seconds of wall time while a task runs (counted from
the task's start at the latest: whoever starts a task must stay to supervise it); when none
comes, the robot stops under control and the session goes to ERROR until `reset`.
"""

from __future__ import annotations

import itertools
import queue
import threading
import time
from collections import deque
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from ..engine.blackboard import Blackboard
from ..engine.episode import make_controller
from ..engine.runner import Observer, make_context
from ..engine.safety_stop import SafetyStop
from ..engine.step import StepLoop
from ..exceptions import ConfigError
from ..language.load import load_scenario
from ..language.machine import ESTOP, PAUSE, RESUME
from ..world.world import World
from .blocked import Blocked
from .guardrail import GoalRejected, check_goals
from .inputs import parse_sets, refuse_non_inputs
from .protocol import PRIORITY, Command, Reply
from .task import Task

__all__ = ["GRIPPER_SKILLS", "RECOVER", "Session"]

RECOVER = "recover"
"""The bundled recovery machine the `recover` command runs."""
GRIPPER_SKILLS = ("grasp", "release")
"""Skills during which the published state is GRASPING (else MOVING)."""
STATUS_PERIOD_S = 0.1
"""Wall time between two status messages (10 Hz) [s]."""

Publish = Callable[[str, dict[str, Any]], None]


class Session:
    """The live session's state and loop.

    Args:
        scenario: Scenario file or bundled name (the world; its machine is the default task).
        name: The session's name (its Zenoh keys live under `orchestrator/<name>/`).
        seed: The world's seed.
        speed: Simulated seconds per wall second while a task runs (0: as fast as possible).
        watchdog_s: Longest wall time between two client heartbeats (None: no watchdog) [s].
        publish: Called with (leaf key, message) for status, heartbeat and events.
        recorder: Makes the observer that records a task (a Rerun recording per task).

    Raises:
        ConfigError: The scenario does not load.
    """

    def __init__(
        self,
        scenario: str,
        name: str,
        seed: int = 0,
        speed: float = 1.0,
        watchdog_s: float | None = None,
        publish: Publish | None = None,
        recorder: Callable[[Task], Observer] | None = None,
        allow_paths: Sequence[Path | str] = (),
    ) -> None:
        self.recorder = recorder
        self.allow_paths = tuple(allow_paths)
        """Directories besides the scenario's tree that a task's machine may come from."""
        self._observer: Observer | None = None
        self.scenario_ref, self.name, self.speed, self.watchdog_s = (
            scenario,
            name,
            speed,
            watchdog_s,
        )
        self.loaded = load_scenario(scenario, allow_paths=self.allow_paths)
        scn = self.loaded.scenario
        self.world = world = World.build(scn, seed)
        dt = float(world.model.opt.timestep)
        self.controller = make_controller(world, seed)
        self.n_sub = max(1, round(1.0 / (scn.physics.control_hz * dt)))
        self.ctx = make_context(world, self.controller, Blackboard({}), seed, self.n_sub * dt)
        self.loop = StepLoop(self.ctx, self.n_sub)
        """Steps the world, task or not: the same code as `orchestrator run`'s."""
        mujoco.mj_forward(world.model, world.data)
        self.publish: Publish = publish or (lambda leaf, msg: None)
        self.inbox: queue.SimpleQueue[tuple[int, int, Command, Any, int, float]] = (
            queue.SimpleQueue()
        )
        self._order = itertools.count()
        self._ids = itertools.count(1)
        self.tasks: deque[Task] = deque()
        self.task: Task | None = None
        self.estopped = False
        self.error: str | None = None
        self.last_result: dict[str, Any] | None = None
        self.idle_stop: SafetyStop | None = None
        self.heartbeat_wall: float | None = None
        self.shutting_down = False
        self._reset_pending = False
        self.ticks = 0
        self.last_estop: dict[str, Any] | None = None
        """The last e-stop's latency: control ticks started and wall time [ms] from its
        arrival (the command answered) to its effect (the abort, the stop begun)."""
        self._lock = threading.Lock()
        self._wall0 = time.perf_counter()
        self._anchor = (self._wall0, 0.0, -1.0)
        self._next_status = 0.0
        scene = self.loaded.scenario.scene
        self.scene = {"objects": [o.name for o in scene.objects],
                      "markers": [m.name for m in scene.markers]}  # fmt: skip
        """The scene's names (in the status: a planner proposes goals with them)."""
        self.rt_window: deque[tuple[float, float]] = deque(maxlen=200)
        """(wall, simulated time) of the last ticks, for the real-time factor."""
        self.blocked = Blocked(self.loaded, self.ctx)
        """The guards every task starts with, checked on the idle world after every control
        tick (BLOCKED; not before the first: the controller has not commanded anything yet)."""
        self._published_state = self.state
        """The state last published (its changes are events)."""

    # -- commands (any thread) ----------------------------------------------------------
    def heartbeat(self, client: str = "") -> None:
        """A client is alive (a message on `clients/heartbeat`; commands do not count)."""
        self.heartbeat_wall = time.perf_counter()

    def submit(self, cmd: Command) -> Reply:
        """Check a command and queue it: the answer is immediate, the effect comes at the
        start of the next control tick."""
        op = cmd.op
        if op == "status":
            return Reply(accepted=True, status=self.status())
        if self.shutting_down and op != "estop":
            return Reply(accepted=False, reason="the session is shutting down")
        payload: Any = None
        if op == "recover":  # the bundled recovery machine, with its own values only
            if cmd.set or cmd.machine:
                return Reply(accepted=False, reason="recover: takes no machine and no values")
            cmd = cmd.model_copy(update={"machine": RECOVER})
        if op in ("run", "recover"):
            rejected, payload = self._prepare(cmd)
            if rejected is not None:
                return Reply(accepted=False, reason=rejected)
        else:
            why = self._refuse(op)
            if why is not None:
                return Reply(accepted=False, reason=why)
        task_id = payload.id if isinstance(payload, Task) else None
        if op == "reset":  # a `run` right behind it is applied after it: accept that too
            self._reset_pending = True
        elif op == "estop":
            self._reset_pending = False
        arrived = (self.ticks, time.perf_counter())
        self.inbox.put((PRIORITY[op], next(self._order), cmd, payload, *arrived))
        return Reply(accepted=True, task=task_id)

    def _refuse(self, op: str) -> str | None:
        running = self.task is not None and self.task.executor is not None
        paused = running and self.task.executor.paused  # type: ignore[union-attr]
        if op in ("pause", "stop") and not running and not self.tasks:
            return f"no task is running (state {self.state})"
        if op == "resume" and not paused:
            return f"nothing is paused (state {self.state})"
        if op == "reset" and not (self.estopped or self.error):
            return f"nothing to reset: the robot is {self.state}"
        return None

    def _prepare(self, cmd: Command) -> tuple[str | None, Task | None]:
        if (self.estopped or self.error) and not self._reset_pending:
            return f"the robot is {self.state}: send `reset` first", None
        machine = cmd.machine or self.loaded.scenario.machine
        overrides, refused = parse_sets(cmd.set)  # inputs only: never a scenario value
        if refused is not None:
            return refused, None
        try:
            loaded = load_scenario(
                self.scenario_ref, cmd.set, allow_paths=self.allow_paths, machine=machine
            )
        except ConfigError as exc:
            return str(exc), None
        keys = [o.path[0] for o in overrides]
        refused = refuse_non_inputs(loaded.machine, keys)
        if refused is not None:
            return refused, None
        refused = self._refuse_blocked(loaded.machine.recovery)
        if refused is not None:
            return refused, None
        q_arm = self.world.data.qpos[self.world.arm_qpos].copy()
        try:
            with self._lock:
                check_goals(loaded, keys, self.world, q_arm)
        except GoalRejected as exc:
            return f"goal rejected: {exc}", None
        return None, Task(next(self._ids), loaded, self.ctx, machine, self.loop)

    def _refuse_blocked(self, recovery: bool) -> str | None:
        """While BLOCKED only a recovery machine may start, and only if moving can help."""
        if self.blocked.violation is None or self.task is not None:
            return None  # a running task's end is checked again before the next one starts
        if not recovery:
            return (
                f"the robot is BLOCKED: {self.blocked.why()}: every task would abort at once; "
                "send `recover` first (it backs the arm out, every guard active)"
            )
        if not self.blocked.recoverable:
            return (
                f"the robot is BLOCKED: {self.blocked.why()}: moving the arm cannot undo "
                "this (a fault, not a place); find its cause and restart the session"
            )
        return None

    # -- the published state ------------------------------------------------------------
    @property
    def state(self) -> str:
        """IDLE, MOVING, GRASPING, PAUSED, BLOCKED, ESTOPPED or ERROR."""
        if self.estopped:
            return "ESTOPPED"
        if self.error:
            return "ERROR"
        task = self.task
        if task is None or task.executor is None:
            return "BLOCKED" if self.blocked.violation is not None else "IDLE"
        ex = task.executor
        if ex.paused:
            return "PAUSED"
        skill = None
        if ex.region is not None and not ex.done:
            for region in ex.region.regions():
                if region.final is None and region.spec.skill:
                    skill = region.spec.skill
        return "GRASPING" if skill in GRIPPER_SKILLS else "MOVING"

    def status(self) -> dict[str, Any]:
        """The status message (also the `status` command's answer)."""
        task = self.task
        wall = time.perf_counter()
        rt = None
        if len(self.rt_window) >= 2:
            (w0, s0), (w1, s1) = self.rt_window[0], self.rt_window[-1]
            rt = round((s1 - s0) / (w1 - w0), 4) if w1 > w0 else None
        return {
            "session": self.name,
            "state": self.state,
            "task": None
            if task is None
            else {"id": task.id, "machine": task.machine_ref, "leaf": task.leaf},
            "queued": len(self.tasks),
            "last_result": self.last_result,
            "error": self.error,
            "sim_time": round(self.ctx.t, 4),
            "wall_time": round(wall - self._wall0, 4),
            "realtime_factor": rt,
            "speed": self.speed,
            "watchdog_s": self.watchdog_s,
            "tcp": np.round(self.ctx.tcp_pos, 5).tolist(),
            "blocked": self.blocked.to_dict(),
            "scene": self.scene,
            "last_estop": self.last_estop,
        }

    # -- the loop (one thread) ----------------------------------------------------------
    def run(self, stop: threading.Event | None = None) -> None:
        """Step the world until `shutdown` (or `stop` is set)."""
        while not (stop is not None and stop.is_set()):
            self._drain()
            self._watchdog()
            if self.shutting_down and self.task is None:
                break
            if self.task is None and self.tasks and not (self.estopped or self.error):
                self._start_next()
            self._tick()
            self._after_tick()
            self._status_if_due()
            self._pace()
        self.publish("events", {"event": "shutdown"})

    def _start_next(self) -> None:
        """Start the next task, unless the world is BLOCKED and it is no recovery machine."""
        task = self.tasks.popleft()
        if self.blocked.violation is not None and not task.loaded.machine.recovery:
            self._task_end_rejected(task)
            return
        self._start(task)

    def _after_tick(self) -> None:
        """The idle world's guards (BLOCKED), and an event for every change of the state."""
        if self.task is None:
            self.blocked.check(self.ctx)
        state = self.state
        if state != self._published_state:
            event: dict[str, Any] = {"event": "state", "from": self._published_state,
                                     "to": state, "t": round(self.ctx.t, 4)}  # fmt: skip
            if self.task is not None:
                event["task"] = self.task.id
            if state == "BLOCKED":
                event["blocked"] = self.blocked.to_dict()
            self._published_state = state
            self.publish("events", event)

    def _start(self, task: Task) -> None:
        """Start `task` on the world (with its recorder, if the session records)."""
        self.blocked.task_started()
        self.task = task
        self._observer = self.recorder(task) if self.recorder is not None else None
        task.start([self._observer] if self._observer is not None else [])
        self.publish("events", {"event": "task_start", "task": task.id,
                                "machine": task.machine_ref})  # fmt: skip

    def _drain(self) -> None:
        items = []
        while True:
            try:
                items.append(self.inbox.get_nowait())
            except queue.Empty:
                break
        # an estop outranks a reset sent before it in the same tick: that reset is void
        estops = [order for _, order, cmd, *_ in items if cmd.op == "estop"]
        last_estop = max(estops, default=-1)
        for _, order, cmd, payload, tick, wall in sorted(items, key=lambda i: (i[0], i[1])):
            if cmd.op == "reset" and order < last_estop:
                continue
            self._apply(cmd, payload, tick, wall)

    def _apply(self, cmd: Command, payload: Any, arrived: int, wall: float) -> None:
        op, source = cmd.op, f"command from {cmd.client or 'a client'}"
        task = self.task
        running = task is not None and task.executor is not None and not task.executor.done
        if op == "estop":
            self.estopped = True
            self.tasks.clear()
            if running:
                task.executor.event(ESTOP, source)  # type: ignore[union-attr]
            elif self.idle_stop is None or not self.idle_stop.active:
                self.idle_stop = SafetyStop(self.ctx, self.loaded.scenario.physics.safe_stop)
                self.idle_stop.start("estop")
            self.last_estop = {
                "ticks": self.ticks - arrived,
                "ms": round((time.perf_counter() - wall) * 1000.0, 3),
                "t": round(self.ctx.t, 4),
            }
            self.publish("events", {"event": "estop", **self.last_estop, "source": source})
        elif op in ("stop", "shutdown"):
            self.tasks.clear()
            if running:
                task.stop(f"{op} command")  # type: ignore[union-attr]
            self.shutting_down = self.shutting_down or op == "shutdown"
        elif op in ("pause", "resume"):
            if running:
                task.executor.event(PAUSE if op == "pause" else RESUME, source)  # type: ignore[union-attr]
        elif op == "reset":
            self.estopped, self.error, self._reset_pending = False, None, False
            self.publish("events", {"event": "reset"})
        elif op in ("run", "recover") and isinstance(payload, Task):
            if self.estopped or self.error:
                self._task_end_rejected(payload)
            else:
                self.tasks.append(payload)

    def _task_end_rejected(self, task: Task) -> None:
        self.publish("events", {"event": "task_end", "task": task.id, "result": None,
                                "reason": f"not started: the robot is {self.state}"})  # fmt: skip

    def _watchdog(self) -> None:
        """While a task runs, a client must prove it is alive every `watchdog_s` (counted
        from the task's start at the latest): an idle robot needs no supervisor."""
        task = self.task
        if self.watchdog_s is None or self.error or task is None or task.executor is None:
            return
        if task.executor.done:
            return
        last = max(self.heartbeat_wall or 0.0, task.wall0)
        silent = time.perf_counter() - last
        if silent < self.watchdog_s:
            return
        self.error = f"watchdog: no client heartbeat for {silent:.3f} s (limit {self.watchdog_s} s)"
        self.tasks.clear()
        task.executor.trip("watchdog", self.error, round(silent, 4), self.watchdog_s)
        self.publish("events", {"event": "watchdog", "message": self.error})

    def _tick(self) -> None:
        """One control tick: the task's (machine, end of task, physics), or the idle world's
        physics (an e-stop's controlled stop, a conveyor that runs task or not)."""
        task = self.task
        stepped = False
        if task is not None:
            finished = task.tick()
            assert task.episode is not None
            stepped = not finished or task.episode.diverged is not None
            if finished:
                self._task_end(task)
        if not stepped:
            stop = self.idle_stop if self.idle_stop is not None and self.idle_stop.active else None
            diverged = self.loop.tick(None, stop)
            if diverged is not None and self.error is None:
                self.error = diverged
        self.ticks += 1

    def _task_end(self, task: Task) -> None:
        result = task.result
        assert result is not None and task.executor is not None
        obs = self._observer
        self.loop.set_observers([])  # the idle world is not recorded
        if obs is not None:
            obs.on_end(self.ctx, task.executor, result)
            self._observer = None
        self.last_result = {
            "task": task.id,
            "machine": task.machine_ref,
            **result.to_json_dict(),
            "exit_code": result.exit_code,
        }
        self.publish("events", {"event": "task_end", "task": task.id, "result": self.last_result})
        diverged = task.episode.diverged if task.episode is not None else None
        if diverged is not None and self.error is None:
            self.error = diverged
        self.task = None

    def _status_if_due(self) -> None:
        wall = time.perf_counter()
        self.rt_window.append((wall, self.ctx.t))
        if wall >= self._next_status:
            self._next_status = wall + STATUS_PERIOD_S
            self.publish("status", self.status())
            self.publish("heartbeat", {"t": round(wall - self._wall0, 4), "tick": self.ticks})

    def _pace(self) -> None:
        busy = self.task is not None and not (self.task.executor and self.task.executor.paused)
        speed = self.speed if busy else (self.speed or 1.0)
        wall0, sim0, anchored_speed = self._anchor
        now, sim = time.perf_counter(), self.ctx.t
        if speed != anchored_speed:
            self._anchor = (now, sim, speed)
            return
        if speed <= 0.0:
            return
        ahead = wall0 + (sim - sim0) / speed - now
        if ahead > 0.0005:
            time.sleep(ahead)
        elif ahead < -0.5:  # cannot keep up: start counting again from here
            self._anchor = (now, sim, speed)
