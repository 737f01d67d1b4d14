"""One task of a live session: a machine run on the session's world, one control tick at a time.

The session's world, controller and context persist between tasks (the cube stays where the
last task put it, the gripper keeps its grip); each task gets its own executor, guards,
blackboard and result. The end of a task is the end of an episode in `orchestrator run`:
after an abort the controlled stop brings the arm to rest; otherwise the arm is brought to
rest gently and the scene settles for `SETTLE_S` before success is judged.
"""

from __future__ import annotations

import math
import time
from typing import Any

import numpy as np

from ..engine.context import Context
from ..engine.executor import Executor, Stopper
from ..engine.result import RunResult
from ..engine.runner import SETTLE_S, initial_blackboard, make_guards
from ..engine.safety_stop import SafetyStop
from ..engine.success import evaluate
from ..language.load import LoadedScenario
from ..language.machine import SAFE_STOP

__all__ = ["Task"]


class Task:
    """A machine running in a session.

    Args:
        task_id: The session's number for it.
        loaded: The task's machine, loaded with the scenario and the command's `--set`.
        ctx: The session's context (its blackboard and metrics are replaced).
        machine_ref: The machine as the command named it.
    """

    def __init__(self, task_id: int, loaded: LoadedScenario, ctx: Context, machine_ref: str):
        self.id = task_id
        self.loaded = loaded
        self.ctx = ctx
        self.machine_ref = machine_ref
        self.executor: Executor | None = None
        self.end_stop: Stopper | None = None
        self.settle_until = math.inf
        self.t0 = 0.0
        self.wall0 = 0.0
        self.result: RunResult | None = None
        self.stopped_by: str | None = None

    # -- lifecycle ------------------------------------------------------------------------
    def start(self) -> None:
        ctx, scn = self.ctx, self.loaded.scenario
        ctx.world.release_brakes()  # engaged by the last task's stop, if any: motors take over
        ctx.blackboard = initial_blackboard(self.loaded.machine, scn.blackboard)
        ctx.metrics = {}
        ctx.clock_offset = 0.0
        ctx.clock_rate = 1.0
        ctx.ik_target = None
        ctx.planned_path = None
        safe_stop = scn.physics.safe_stop
        self.executor = Executor(
            self.loaded.machine,
            ctx,
            make_guards(scn.guards, ctx),
            lambda: SafetyStop(ctx, safe_stop),
            safe_stop.hold_s,
        )
        self.t0, self.wall0 = ctx.t, time.perf_counter()  # clock_offset is 0: clock == t
        self.executor.start()

    @property
    def leaf(self) -> str:
        return self.executor.leaf if self.executor is not None else ""

    @property
    def active_stop(self) -> Stopper | None:
        """The controlled stop the physics step must drive, if one is under way."""
        ex = self.executor
        stop = self.end_stop if self.end_stop is not None else (ex.stop if ex else None)
        return stop if stop is not None and stop.active else None

    def stop(self, reason: str) -> None:
        """The `stop` command: a machine that declares a `stop` event gets it (its own way of
        stopping, e.g. `events: {stop: GO_HOME}`); any other ends where it is (`failed`, the
        arm brought to rest gently)."""
        ex = self.executor
        if ex is None or ex.done:
            return
        self.stopped_by = reason
        if "stop" in ex.root.events:
            ex.event("stop", reason)
        else:
            ex.halt()

    def tick(self) -> bool:
        """One control tick of the machine and of the end of the task.

        Returns:
            True when the task is over (the arm at rest, the result built).
        """
        ex, ctx = self.executor, self.ctx
        assert ex is not None
        if not ex.done:
            ex.tick()
            limit = self.loaded.scenario.physics.time_limit_s
            if not ex.done and ctx.clock - self.t0 >= limit:  # a pause is not counted
                self.stopped_by = f"time limit ({limit} s)"
                ex.halt()
        if not ex.done:
            return False
        if self.end_stop is None:
            abort_stop = ex.stop
            if ex.outcome == "aborted" and ex.final_state == SAFE_STOP:
                if abort_stop is not None and not abort_stop.active:
                    self._finish()
                    return True
                return False
            if abort_stop is not None and abort_stop.active:
                self.end_stop = abort_stop
            else:
                gentle = SafetyStop(ctx, self.loaded.scenario.physics.safe_stop)
                gentle.start("end of task", gentle=ex.violation is None)
                self.end_stop = gentle
            self.settle_until = ctx.t + (0.0 if ex.violation else SETTLE_S)
        stop = self.end_stop
        if (stop.at_rest and ctx.t >= self.settle_until - 1e-9) or stop.timed_out():
            self._finish()
            return True
        return False

    # -- the result -----------------------------------------------------------------------
    def _finish(self) -> None:
        ex, ctx, scn = self.executor, self.ctx, self.loaded.scenario
        assert ex is not None
        outcome = ex.outcome or "failed"
        judged = evaluate(ctx, scn.success)
        success = {name: ok for name, (ok, _) in judged.items()}
        if outcome == "succeeded" and not all(success.values()):
            outcome = "failed"
        metrics: dict[str, Any] = {
            "cycle_time": round(ex.final_t - self.t0, 6) if ex.final_t is not None else None,
            "t_start": round(self.t0, 6),
        }
        metrics.update(ctx.metrics)
        if ex.violation is not None and ex.stop is not None:
            metrics["abort_t"] = round((ex.violation_t or 0.0) - self.t0, 6)
            if ex.stop.stop_time_s is not None:
                metrics["stop_time_s"] = round(ex.stop.stop_time_s, 4)
            metrics["stop_distance_mm"] = round(ex.stop.distance_m * 1000.0, 3)
        if ex.events:
            metrics["events"] = ex.events
        if ex.pause.pauses:
            metrics["pauses"] = ex.pause.pauses
        if self.stopped_by is not None:
            metrics["stopped_by"] = self.stopped_by
        data, world = ctx.data, ctx.world
        metrics["rest_speed_rad_s"] = round(float(np.max(np.abs(data.qvel[world.arm_dof]))), 5)
        self.result = RunResult(
            scenario=scn.name,
            seed=world.seed,
            outcome=outcome,  # type: ignore[arg-type]
            final_state=ex.final_state,
            reason=ex.violation.to_dict() if ex.violation else None,
            sim_time=round(ctx.t - self.t0, 6),
            wall_time=round(time.perf_counter() - self.wall0, 4),
            transitions=ex.transitions,
            metrics=metrics,
            success=success,
            retries=ex.retries,
            success_detail={name: text for name, (_, text) in judged.items()},
        )
