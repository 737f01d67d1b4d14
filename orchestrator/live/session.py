"""A live session: a world kept running, the robot idle and holding until a command arrives.

Commands come from any thread through `submit` (the Zenoh server's callbacks call it): it
answers at once, accepted or rejected with the reason, after checking what it can without
touching the world (a task's machine and `--set` values are loaded and validated, its goals
go through the guardrail). Accepted commands wait in an inbox that the session's loop drains
at the start of every control tick, highest priority first (`estop` > `stop`, `shutdown` >
`pause`, `resume`, `reset` > `run`, `recover`); tasks run one after another, first in first
out. `estop` (any thread, `Session.estop`) takes no lock and wakes the loop: it is applied at the
start of the next control tick whatever the command handlers are doing.

The queue policy: a `run` while a task runs or waits is refused, naming the running task
(`queue_limit` 0, the default), or waits behind it while fewer than `queue_limit` tasks wait;
a `run` with `preempt` stops the running task under control, drops the queue, and runs next.
Task ids are `<epoch>-<n>`: the epoch is random per session, so no id is reused when a
session restarts and a client waiting on a task never takes another task's result.

Only the task machine's inputs may be set (live/inputs.py): limits are the scenario's. While no
task runs, the guards every task starts with are checked on the idle world (live/blocked.py):
a violated one makes the state BLOCKED, and then only a recovery machine (`recover`) may start.
Every change of the published state is an `events` message (`{"event": "state", ...}`).

Simulated time is paced to the wall clock: `speed` 1 is real time, 2 twice as fast, 0 as
fast as the machine can (while a task runs; an idle or paused robot is kept at real time:
there is nothing to hurry and the CPU is left to others). A paused task's time limit stands
still with its clock. A watchdog, when set, expects a heartbeat from the task's *owner*
(the client that sent the `run`: its heartbeats carry the owner token of the command) at
least every `watchdog_s` seconds of wall time while the task runs (counted from the task's
start at the latest: whoever starts a task must stay to supervise it; a bystander's
heartbeats do not count); when none comes, the robot stops under control and the session
goes to ERROR until `reset`. A queued task whose owner fell silent is dropped unstarted.
"""

from __future__ import annotations

import itertools
import queue
import threading
import time
import traceback
import uuid
from collections import deque
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import mujoco

from ..engine.blackboard import Blackboard
from ..engine.cell import Cell
from ..engine.context import Context
from ..engine.prepare import prepare
from ..engine.runner import Observer
from ..engine.safety_stop import SafetyStop
from ..engine.step import StepLoop
from ..exceptions import ConfigError
from ..language.load import load_scenario
from ..language.machine import PAUSE, RESUME
from . import machine_ref, supervision
from .blocked import Blocked
from .guardrail import GoalRejected, check_goals
from .inputs import parse_sets, refuse_non_inputs
from .motion import MotionProbe
from .protocol import PRIORITY, Command, Reply
from .snapshot_writer import SNAPSHOT_BYTES, SNAPSHOT_COUNT, SnapshotWriter
from .supervision import blocked_refusal, busy_reason, idle_refusal, status_message, watchdog
from .task import Closeable, Task
from .time_travel import TIME_TRAVEL, apply_time_travel, capture, submit_time_travel

if TYPE_CHECKING:
    from ..world.world import World

__all__ = ["GRIPPER_SKILLS", "RECOVER", "Session"]

RECOVER = "recover"
MOTION_OPS = ("run", "recover", "resume", "restore", "reload")
"""Commands that may set the arm moving: each one is checked against the latch (ESTOPPED,
ERROR) when it is applied on the control loop, not only when it arrives (an e-stop may land
in between: it is applied first and the command is then refused)."""
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
        watchdog_s: Longest wall time between two heartbeats of a running task's owner
            (None: no watchdog; `orchestrator serve` sets 1 s unless told otherwise) [s].
        publish: Called with (leaf key, message) for status, heartbeat and events.
        recorder: Makes the observer that records a task (a Rerun recording per task).
        allow_paths: Directories besides the scenario's tree a task's machine may come from.
        queue_limit: Tasks that may wait behind the running one (0: a `run` while busy is
            refused).
        snapshot_dir: Where `snapshot` writes and `restore` reads.
        snapshot_count: Snapshots the session may write in all (the cap).
        snapshot_bytes: Bytes of snapshots the session may write in all (the cap).

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
        queue_limit: int = 0,
        snapshot_dir: Path | str | None = None,
        snapshot_count: int = SNAPSHOT_COUNT,
        snapshot_bytes: int = SNAPSHOT_BYTES,
    ) -> None:
        self.snapshot_dir = Path(snapshot_dir) if snapshot_dir is not None else Path("snapshots")
        """Where `snapshot` writes and `restore` reads (live/snapshots.py)."""
        self.snapshots = SnapshotWriter(lambda path: capture(self, path), lambda: self.publish,
                                        snapshot_count, snapshot_bytes)  # fmt: skip
        """Writes snapshots off the loop, under the session's cap (live/snapshot_writer.py)."""
        self.recorder = recorder
        self.allow_paths = tuple(allow_paths)
        """Directories besides the scenario's tree that a task's machine may come from."""
        self._observer: Observer | None = None
        self.scenario_ref, self.name = scenario, name
        self.speed, self.watchdog_s = speed, watchdog_s
        prepared = prepare(scenario, seed, allow_paths=self.allow_paths)  # as `run` does
        self.loaded = prepared.loaded
        assert prepared.world is not None
        self.cell = Cell.build(self.loaded.scenario, seed, prepared.world)
        """The world and the robot's hardware, kept from task to task (the same assembly as
        `orchestrator run`'s, engine/cell.py); its step loop steps the world, task or not."""
        self.ctx = Context(self.cell, Blackboard({}))
        """The idle world's context (between tasks: an e-stop's stop, the BLOCKED check);
        each task runs in a fresh context of its own (`Task.ctx`)."""
        self.probe = MotionProbe(self.world.arm_dof)
        """The arm's peak joint speed on every physics step (in the status: `arm_speed`)."""
        self._idle_loop()
        mujoco.mj_forward(self.world.model, self.world.data)
        self.publish: Publish = publish or (lambda leaf, msg: None)
        self.inbox: queue.SimpleQueue[tuple[int, int, Command, Any, int, float]]
        self.inbox = queue.SimpleQueue()
        self._order = itertools.count()
        self.epoch = uuid.uuid4().hex[:8]
        """This session's random epoch: the first part of every task id."""
        self._ids = (f"{self.epoch}-{n}" for n in itertools.count(1))
        self.queue_limit = queue_limit
        self._pending: dict[str, Task] = {}
        """Accepted `run`s still in the inbox, by id (admission counts them)."""
        self._admit = threading.Lock()
        """Serializes admission between command handlers (the loop never takes it)."""
        self._wake = threading.Event()
        """Set by an e-stop: the loop's pacing sleep ends at once."""
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

    @property
    def world(self) -> World:
        """The session's world (its cell's)."""
        return self.cell.world

    @property
    def loop(self) -> StepLoop:
        """Steps the world, task or not: the same code as `orchestrator run`'s."""
        return self.cell.loop

    def _idle_loop(self) -> None:
        """Step for the idle world: its own context (a task's is let go), not recorded."""
        self.loop.bind(self.ctx)
        self.loop.set_observers([self.probe])

    # -- commands (any thread) ----------------------------------------------------------
    def heartbeat(self, owner: str = "") -> None:
        """A heartbeat carrying `owner` (a message on `clients/heartbeat`; commands do not
        count): it feeds the watchdog of the tasks that owner sent, and nobody else's."""
        now = time.perf_counter()
        self.heartbeat_wall = now
        if not owner:
            return
        for task in (self.task, *list(self.tasks)):
            if task is not None and task.owner == owner:
                task.beat_wall = now

    def estop(self, source: str = "the e-stop key") -> Reply:
        """The e-stop, from any thread: never refused, no lock taken, the loop woken; it is
        applied at the start of the next control tick. `source` says where it came from (in
        the task's events and the `estop` event)."""
        self._reset_pending = False
        cmd = Command(op="estop", client=source[:128])
        self.inbox.put((PRIORITY["estop"], next(self._order), cmd, None, self.ticks,
                        time.perf_counter()))  # fmt: skip
        self._wake.set()
        return Reply(accepted=True)

    def busy(self, cmd: Command) -> str | None:
        """Why a `run` cannot be admitted under the queue policy now (None: it can). Cheap:
        checked before a `run` is loaded, and again before it is queued (live/supervision.py)."""
        return busy_reason(self, cmd)

    def submit(self, cmd: Command) -> Reply:
        """Check a command and queue it: the answer is immediate, the effect comes at the
        start of the next control tick."""
        op = cmd.op
        if op == "status":
            return Reply(accepted=True, status=self.status())
        if op == "estop":
            return self.estop(f"command from {cmd.client or 'a client'}")
        if self.shutting_down:
            return Reply(accepted=False, reason="the session is shutting down")
        payload: Any = None
        if op == "recover":  # the bundled recovery machine, with its own values only
            if cmd.set or cmd.machine:
                return Reply(accepted=False, reason="recover: takes no machine and no values")
            cmd = cmd.model_copy(update={"machine": RECOVER})
        if op in ("run", "recover"):
            why = self.busy(cmd)
            if why is not None:  # before loading anything: a flood of runs costs nothing
                return Reply(accepted=False, reason=why)
            rejected, payload = self._prepare(cmd)
            if rejected is not None:
                return Reply(accepted=False, reason=rejected)
            return self._admit_run(cmd, payload)
        if op in TIME_TRAVEL:  # snapshot, restore, reload (live/time_travel.py)
            reply, payload = submit_time_travel(self, cmd)
            if reply.accepted:
                self._enqueue(cmd, payload)
            return reply
        why = idle_refusal(self, op)
        if why is not None:
            return Reply(accepted=False, reason=why)
        if op == "reset":  # a `run` right behind it is applied after it: accept that too
            self._reset_pending = True
        self._enqueue(cmd, None)
        return Reply(accepted=True)

    def _admit_run(self, cmd: Command, task: Any) -> Reply:
        with self._admit:
            why = self.busy(cmd)  # another run may have been admitted while this one loaded
            if why is not None:
                return Reply(accepted=False, reason=why)
            task.owner, task.client = cmd.owner, cmd.client
            task.accepted_wall = time.perf_counter()
            self._pending[task.id] = task
            self._enqueue(cmd, task)
        return Reply(accepted=True, task=task.id)

    def _enqueue(self, cmd: Command, payload: Any) -> None:
        arrived = (self.ticks, time.perf_counter())
        self.inbox.put((PRIORITY[cmd.op], next(self._order), cmd, payload, *arrived))

    def _prepare(self, cmd: Command) -> tuple[str | None, Task | None]:
        if (self.estopped or self.error) and not self._reset_pending:
            return f"the robot is {self.state}: send `reset` first", None
        machine = cmd.machine or self.loaded.scenario.machine
        overrides, refused = parse_sets(cmd.set)  # inputs only: never a scenario value
        if refused is None and cmd.machine:  # one answer for missing and not allowed
            refused = machine_ref.refusal(cmd.machine, self.loaded.path, self.allow_paths)
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
        refused = blocked_refusal(self, loaded.machine.recovery)
        if refused is not None:
            return refused, None
        q_arm = self.world.data.qpos[self.world.arm_qpos].copy()
        try:
            with self._lock:
                check_goals(loaded, keys, self.world, q_arm)
        except GoalRejected as exc:
            return f"goal rejected: {exc}", None
        return None, Task(next(self._ids), loaded, self.cell, machine)

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
        """The status message (also the `status` command's answer; live/supervision.py)."""
        return status_message(self)

    def published_status(self) -> dict[str, Any]:
        """The periodic status: `status()` and the arm's peak joint speed on every physics
        step since the previous one (`arm_speed`, live/motion.py)."""
        return {**self.status(), "arm_speed": self.probe.window()}

    def observers(self) -> list[Observer]:
        """What watches the step loop: the task's recorder, if any, and the motion probe."""
        return [o for o in (self._observer, self.probe) if o is not None]

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
        self.snapshots.close()
        self.publish("events", {"event": "shutdown"})

    def _start_next(self) -> None:
        """Start the next task, unless the world is BLOCKED and it is no recovery machine.
        A task is running before it leaves the queue: `busy` never sees a moment with neither."""
        task = self.tasks[0]
        if self.blocked.violation is not None and not task.loaded.machine.recovery:
            self.tasks.popleft()
            self._task_end_rejected(task)
            return
        self._start(task)
        self.tasks.popleft()

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
        task.start(self.observers(), self.cell)  # the world now (a restore replaces it)
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
            try:
                self._apply(cmd, payload, tick, wall)
            except Exception as exc:  # a bug in one command must not end the session
                self._internal_error(cmd, payload, exc)
        # after the commands (an e-stop first): a snapshot captures the state they left
        self.snapshots.tick(lambda: {"t": round(self.ctx.t, 6), "tick": self.ctx.tick})

    def _internal_error(self, cmd: Command, payload: Any, exc: Exception) -> None:
        """A command's effect failed: stop what runs under control and go to ERROR (until
        `reset`), as a robot's controller does on a software fault."""
        traceback.print_exc()
        self.error = f"internal error applying {cmd.op}: {type(exc).__name__}: {exc}"[:500]
        if isinstance(payload, Task):
            self._pending.pop(payload.id, None)
        task = self.task
        if task is not None and task.executor is not None and not task.executor.done:
            task.executor.trip("internal_error", self.error)
        self._drop_queue(f"not started: {self.error}")
        self.publish("events", {"event": "internal_error", "message": self.error})

    def _latched_refusal(self, cmd: Command, payload: Any) -> bool:
        """Refuse, as it is applied, a command that may set the arm moving while the robot is
        latched (ESTOPPED, ERROR): only `reset` unlatches. True if it was refused."""
        if cmd.op not in MOTION_OPS or not (self.estopped or self.error):
            return False
        why = f"{cmd.op} refused when applied: the robot is {self.state} (send `reset` first)"
        if isinstance(payload, Task):
            self._pending.pop(payload.id, None)
            self._task_end_rejected(payload, f"not started: {why}")
        self.publish("events", {"event": "refused", "op": cmd.op, "reason": why,
                                "client": cmd.client})  # fmt: skip
        return True

    def _apply(self, cmd: Command, payload: Any, arrived: int, wall: float) -> None:
        op = cmd.op
        if self._latched_refusal(cmd, payload):
            return
        source = cmd.client if op == "estop" else f"command from {cmd.client or 'a client'}"
        task = self.task
        running = task is not None and task.executor is not None and not task.executor.done
        # a command that would change nothing is not delivered again: a flood of them must
        # not grow the task's event log (each delivered event is recorded in its result)
        if op == "estop":
            again = self.estopped  # later ones find the arm stopped; each is measured
            # a task that still drives the arm (running, or bringing it to rest) gives it over
            held = task is not None if again else supervision.estop_task(self, source)
            if not held and (self.idle_stop is None or not self.idle_stop.active):
                self.idle_stop = SafetyStop(self.ctx, self.loaded.scenario.physics.safe_stop)
                self.idle_stop.start("estop")
            self.last_estop = {  # before the state says ESTOPPED: a status has both
                "ticks": self.ticks - arrived,
                "ms": round((time.perf_counter() - wall) * 1000.0, 3),
                "t": round(self.ctx.t, 4),
            }
            self.estopped = True
            self._drop_queue("not started: e-stop")
            self.publish("events", {"event": "estop", **self.last_estop, "source": source})
        elif op in ("stop", "shutdown"):
            self._drop_queue(f"not started: {op} command")
            if running and task.stopped_by is None:  # type: ignore[union-attr]
                task.stop(f"{op} command")  # type: ignore[union-attr]
            self.shutting_down = self.shutting_down or op == "shutdown"
        elif op in ("pause", "resume"):
            if running and task.pause_wanted != (op == "pause"):  # type: ignore[union-attr]
                task.pause_wanted = op == "pause"  # type: ignore[union-attr]
                task.executor.event(PAUSE if op == "pause" else RESUME, source)  # type: ignore[union-attr]
        elif op == "reset":
            self.estopped, self.error, self._reset_pending = False, None, False
            self.publish("events", {"event": "reset"})
        elif op in TIME_TRAVEL:
            apply_time_travel(self, cmd, payload)
        elif op in ("run", "recover") and isinstance(payload, Task):
            if cmd.preempt:  # a controlled stop of what runs; the queue goes; this one next
                why = f"preempted by task {payload.id}"
                self._drop_queue(f"not started: {why}")
                if running and task.stopped_by is None:  # type: ignore[union-attr]
                    task.stop(why)  # type: ignore[union-attr]
            self.tasks.append(payload)
            self._pending.pop(payload.id, None)  # after the append: `busy` never undercounts

    # -- time travel (live/time_travel.py) ------------------------------------------------
    def next_task_id(self) -> str:
        """A new task id of this session."""
        return next(self._ids)

    def drop_all(self, reason: str) -> None:
        """Drop the queue and end the running task where it is, without a result (a
        `restore` replaces the world they ran on); their clients are told `reason`."""
        self._drop_queue(f"not started: {reason}")
        task = self.task
        if task is None:
            return
        obs, self._observer = self._observer, None
        self._idle_loop()
        if isinstance(obs, Closeable):
            obs.close()
        self.task = None
        self._task_end_rejected(task, f"ended: {reason}")

    def resume_task(self, task: Task) -> None:
        """Continue `task` restored from a snapshot (with a recorder, if the session
        records: its recording starts at the snapshot's time)."""
        self.task = task
        self._observer = self.recorder(task) if self.recorder is not None else None
        task.resume(self.observers())
        self.publish("events", {"event": "task_start", "task": task.id,
                                "machine": task.machine_ref, "restored": True})  # fmt: skip

    def restarted_clock(self) -> None:
        """Simulated time jumped (a restore): pace from here."""
        self._anchor = (time.perf_counter(), self.ctx.t, -1.0)
        self.rt_window.clear()

    def _task_end_rejected(self, task: Task, reason: str | None = None) -> None:
        why = reason or f"not started: the robot is {self.state}"
        self.publish("events", {"event": "task_end", "task": task.id, "result": None,
                                "reason": why})  # fmt: skip

    def _drop_queue(self, reason: str) -> None:
        """Drop every waiting task, telling each one's client (a `task_end` without result)."""
        while self.tasks:
            self._task_end_rejected(self.tasks.popleft(), reason)

    def _watchdog(self) -> None:
        """The owner's heartbeats (live/supervision.py `watchdog`)."""
        watchdog(self)

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
        assert task.ctx is not None
        if obs is not None:
            obs.on_end(task.ctx, task.executor, result)
            self._observer = None
        self._idle_loop()
        self.last_result = {
            "task": task.id,
            "machine": task.machine_ref,
            **result.to_json_dict(),
            "exit_code": result.exit_code,
        }
        diverged = task.episode.diverged if task.episode is not None else None
        if diverged is not None and self.error is None:
            self.error = diverged
        # The session is free before anyone hears the task ended: a client that sends its next
        # `run` on `task_end` is checked (on the channel's thread) against a session with no task.
        self.task = None
        self.publish("events", {"event": "task_end", "task": task.id, "result": self.last_result})

    def _status_if_due(self) -> None:
        wall = time.perf_counter()
        self.rt_window.append((wall, self.ctx.t))
        if wall >= self._next_status:
            self._next_status = wall + STATUS_PERIOD_S
            self.publish("status", self.published_status())
            self.publish("heartbeat", {"t": round(wall - self._wall0, 4), "tick": self.ticks})

    def _pace(self) -> None:
        """Keep simulated time to the wall clock (live/supervision.py `pace`)."""
        supervision.pace(self)
