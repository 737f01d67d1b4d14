"""What a live session decides about its clients, apart from the control loop: the queue
policy's answer to a `run` (`busy_reason`), why a command would change nothing
(`idle_refusal`) or cannot start while BLOCKED (`blocked_refusal`), the owner's watchdog
(`watchdog`), the status message (`status_message`) and the pacing of simulated time to the
wall clock (`pace`). Functions of the session
(live/session.py) that read and change its state, where the session calls them: admission on
the command threads, the watchdog on the loop, the status for the loop and for queries.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from ..engine.safety_stop import SafetyStop
from ..language.machine import ESTOP
from .protocol import Command

__all__ = [
    "blocked_refusal",
    "busy_reason",
    "estop_task",
    "idle_refusal",
    "pace",
    "status_message",
    "watchdog",
]


def pace(session: Any) -> None:
    """Wait, if simulated time runs ahead of the wall clock at the session's speed (a running
    task at `speed`; an idle or paused robot at real time, or `speed` if set). An e-stop
    ends the wait (`session._wake`); a loop that cannot keep up starts counting again."""
    task = session.task
    busy = task is not None and not (task.executor and task.executor.paused)
    speed = session.speed if busy else (session.speed or 1.0)
    wall0, sim0, anchored_speed = session._anchor
    now, sim = time.perf_counter(), session.ctx.t
    if speed != anchored_speed:
        session._anchor = (now, sim, speed)
        return
    if speed <= 0.0:
        return
    ahead = wall0 + (sim - sim0) / speed - now
    if ahead > 0.0005:
        session._wake.wait(ahead)  # an e-stop ends the wait: its tick starts at once
        session._wake.clear()
    elif ahead < -0.5:  # cannot keep up: start counting again from here
        session._anchor = (now, sim, speed)


def busy_reason(session: Any, cmd: Command) -> str | None:
    """Why a `run` cannot be admitted under the queue policy now (None: it can). Cheap:
    checked before a `run` is loaded, and again before it is queued."""
    if cmd.preempt:
        return None
    running = session.task
    waiting = [*session.tasks, *session._pending.values()]
    if (running is not None) + len(waiting) <= session.queue_limit:
        return None
    if running is not None:
        what = f"task {running.id} ({running.machine_ref}) is running"
    else:
        what = f"task {waiting[0].id} ({waiting[0].machine_ref}) is about to start"
    if session.queue_limit == 0:
        return (
            f"busy: {what} (queue policy: reject while busy); send with --preempt to "
            "stop it under control and run this one, or serve with --queue N"
        )
    return (
        f"busy: {what} and {session.queue_limit} task(s) wait (serve --queue "
        f"{session.queue_limit}); send with --preempt to replace them"
    )


def estop_task(session: Any, source: str) -> bool:
    """Give the session's task, if one still drives the arm, to an e-stop (the loop, as the
    e-stop is applied). A running machine aborts (`estop`: its safety stop, then the holding
    brakes). A machine that has ended while the arm is still being brought to rest (the end
    of a task: a gentle, category-2 stop whose motors hold the arm, and the scene settling)
    has its stop replaced by the e-stop's own (category 1: braked at the safety stop's rate,
    then held by the brakes), and the task ends once that one has the arm at rest.

    Returns:
        False when no task drives the arm (the idle world's e-stop is the session's own).
    """
    task = session.task
    ex, episode = (None, None) if task is None else (task.executor, task.episode)
    if ex is None or episode is None or episode.over:
        return False
    if not ex.done:
        ex.event(ESTOP, source)
        return True
    stop = episode.end_stop
    if stop is None or stop.gentle:  # the end of a task: the motors would hold the arm
        stop = SafetyStop(session.ctx, task.loaded.scenario.physics.safe_stop)
        stop.start(f"estop: {source}")
        episode.end_stop, episode.settle_until = stop, session.ctx.t
    return True


def watchdog(session: Any) -> None:
    """While a task runs, its owner must prove it is alive every `watchdog_s` (counted
    from the task's start at the latest): an idle robot needs no supervisor, and only
    the owner's heartbeats count. A waiting task whose owner is silent that long (since
    it was accepted at the latest) is dropped before it moves anything."""
    limit = session.watchdog_s
    if not limit:
        return
    now = time.perf_counter()
    for waiting in list(session.tasks):
        silent = now - max(waiting.beat_wall or 0.0, waiting.accepted_wall)
        if silent >= limit and waiting is not session.task:
            session.tasks.remove(waiting)
            session._task_end_rejected(waiting, f"not started: its owner "
                                    f"({waiting.client or 'a client'}) sent no heartbeat "
                                    f"for {silent:.3f} s (watchdog {limit} s)")  # fmt: skip
    task = session.task
    if session.error or task is None or task.executor is None or task.executor.done:
        return
    stopped = task.executor.violation
    if session.estopped or (stopped is not None and stopped.guard == ESTOP):
        return  # an e-stopped task is held and ends: its owner's silence moves nothing
    silent = now - max(task.beat_wall or 0.0, task.wall0)
    if silent < limit:
        return
    owner = task.client or "a client"
    session.error = (f"watchdog: no heartbeat from task {task.id}'s owner ({owner}) for "
                  f"{silent:.3f} s (limit {limit} s)")  # fmt: skip
    session._drop_queue(f"not started: {session.error}")
    task.executor.trip("watchdog", session.error, round(silent, 4), limit)
    session.publish("events", {"event": "watchdog", "message": session.error})


def status_message(session: Any) -> dict[str, Any]:
    """The status message (also the `status` command's answer)."""
    task = session.task
    wall = time.perf_counter()
    rt = None
    if len(session.rt_window) >= 2:
        (w0, s0), (w1, s1) = session.rt_window[0], session.rt_window[-1]
        rt = round((s1 - s0) / (w1 - w0), 4) if w1 > w0 else None
    return {
        "session": session.name,
        "epoch": session.epoch,
        "state": session.state,
        "task": None
        if task is None
        else {
            "id": task.id,
            "machine": task.machine_ref,
            "leaf": task.leaf,
            "client": task.client,
        },
        "queued": len(session.tasks),
        "queue_limit": session.queue_limit,
        "last_result": session.last_result,
        "error": session.error,
        "sim_time": round(session.ctx.t, 4),
        "wall_time": round(wall - session._wall0, 4),
        "realtime_factor": rt,
        "speed": session.speed,
        "watchdog_s": session.watchdog_s,
        "tcp": np.round(session.ctx.tcp_pos, 5).tolist(),
        "blocked": session.blocked.to_dict(),
        "scene": session.scene,
        "last_estop": session.last_estop,
    }


def idle_refusal(session: Any, op: str) -> str | None:
    """Why `pause`, `stop`, `resume` or `reset` would change nothing now (None: they would)."""
    running = session.task is not None and session.task.executor is not None
    paused = running and session.task.executor.paused  # type: ignore[union-attr]
    if op in ("pause", "stop") and not running and not session.tasks:
        return f"no task is running (state {session.state})"
    if op == "resume" and not paused:
        return f"nothing is paused (state {session.state})"
    if op == "reset" and not (session.estopped or session.error):
        return f"nothing to reset: the robot is {session.state}"
    return None


def blocked_refusal(session: Any, recovery: bool) -> str | None:
    """While BLOCKED only a recovery machine may start, and only if moving can help."""
    if session.blocked.violation is None or session.task is not None:
        return None  # a running task's end is checked again before the next one starts
    if not recovery:
        return (
            f"the robot is BLOCKED: {session.blocked.why()}: every task would abort at once; "
            "send `recover` first (it backs the arm out, every guard active)"
        )
    if not session.blocked.recoverable:
        return (
            f"the robot is BLOCKED: {session.blocked.why()}: moving the arm cannot undo "
            "this (a fault, not a place); find its cause and restart the session"
        )
    return None
