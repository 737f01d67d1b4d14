"""An episode: one machine run on a world, tick by tick, until the arm is at rest — and its result.

`orchestrator run` (runner.py) runs one on a world of its own; a live session runs one per
task on the world it keeps (live/task.py). Both go through `Episode.tick`, so the end of a
run is the same everywhere: after an abort the controlled stop brings the arm to rest and
holds it; after any other end the arm is brought to rest gently and the scene settles for
`SETTLE_S` before success is judged; the time limit ends the machine where it is.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from functools import partial
from typing import TYPE_CHECKING, Any

import numpy as np

from ..guards import get_guard
from ..guards.base import Guard
from ..language.loading import MachineNode, initial_values
from ..language.machine import SAFE_STOP, guard_entries
from ..robots import Controller
from ..world.realism import link_mass_scale
from .blackboard import Blackboard
from .executor import Executor, Stopper
from .result import RunResult
from .safety_stop import SafetyStop
from .success import errors, evaluate
from .tasks import metrics as task_metrics

if TYPE_CHECKING:
    from ..language.load import LoadedScenario
    from ..world.world import World
    from .context import Context
    from .step import StepLoop

__all__ = [
    "SETTLE_S",
    "Episode",
    "initial_blackboard",
    "make_controller",
    "make_executor",
    "make_guards",
]

SETTLE_S = 0.2
"""Simulated time kept running after the machine finishes, before success is judged [s]."""


def initial_blackboard(machine: MachineNode, overrides: dict[str, Any]) -> Blackboard:
    """Defaults declared in the machine tree (outer levels win), then the scenario's values."""
    return Blackboard(initial_values(machine, overrides))


def make_guards(refs, ctx: Context) -> list[Guard]:
    """The guards `refs` names (a scenario's or a machine's `guards:`), bound to `ctx`."""
    out = []
    for _, name, params in guard_entries(refs):
        cls = get_guard(name)
        guard = cls(cls.Params.model_validate(params))
        guard.bind(ctx)
        out.append(guard)
    return out


def make_controller(world: World, seed: int) -> Controller:
    """The torque controller of `world`'s robot, holding its home pose; its model carries the
    scenario's link-mass mismatch (`physics.realism`) drawn from `seed`."""
    scn = world.scenario
    controller = Controller(
        world.robot,
        float(world.model.opt.timestep),
        link_mass_scale(scn.physics.realism, world.robot.pinocchio_model().njoints - 1, seed),
    )
    controller.hold(world.home)
    return controller


def make_executor(loaded: LoadedScenario, ctx: Context) -> Executor:
    """The executor of `loaded`'s machine with the scenario's guards, the controlled stop of
    `physics.safe_stop`, and the guards that watch every safety response (the joint limits,
    and the stop's force ceiling once the arm is stopped)."""
    safe_stop = loaded.scenario.physics.safe_stop
    return Executor(
        loaded.machine,
        ctx,
        make_guards(loaded.scenario.guards, ctx),
        partial(SafetyStop, ctx, safe_stop),  # a method's partial, not a closure
        safe_stop.hold_s,
        make_guards(["joint_limits"], ctx),
        make_guards([{"contact_force": {"max_n": safe_stop.force_ceiling_n}}], ctx),
    )


class Episode:
    """One machine on a world, from `executor.start()` to the arm at rest.

    Args:
        loaded: The scenario (its time limit, safe stop and success checks).
        ctx: The world's context.
        executor: The machine's executor, not started yet.
        loop: Steps the world (shared by the tasks of a live session).
        observers: Told about every control tick (`on_tick(ctx, executor)`).

    Attributes:
        t0: Simulated time of the start [s] (0 for a run; a live task starts later).
        tick0: Control ticks before the start.
        timed_out: The time limit ended the machine (no guard had fired).
        diverged: Why the physics diverged, if it did (the episode ended there).
    """

    def __init__(
        self,
        loaded: LoadedScenario,
        ctx: Context,
        executor: Executor,
        loop: StepLoop,
        observers: Sequence[Any] = (),
    ) -> None:
        self.loaded = loaded
        self.ctx = ctx
        self.executor = executor
        self.loop = loop
        self.observers = list(observers)
        self.end_stop: Stopper | None = None
        """The controlled stop that ends the episode (the abort's, or a gentle one)."""
        self.settle_until = math.inf
        self.timed_out = False
        self.halt_reason: str | None = None
        """Why the episode was halted from outside (a wall-clock limit, a `stop` command)."""
        self.diverged: str | None = None
        self.over = False
        self.t0 = ctx.t
        self.clock0 = ctx.clock
        self.tick0 = ctx.tick
        self.time_limit_s = loaded.scenario.physics.time_limit_s

    def start(self) -> None:
        """Enter the machine's initial state."""
        self.executor.start()

    @property
    def active_stop(self) -> Stopper | None:
        """The controlled stop the physics steps drive, if one is under way."""
        ex = self.executor
        stop = self.end_stop if self.end_stop is not None else ex.stop
        return stop if stop is not None and stop.active else None

    def halt(self, reason: str) -> None:
        """End the machine where it is (a wall-clock limit, a `stop` command): the arm is
        brought to rest as at the end of any run."""
        if self.halt_reason is None:
            self.halt_reason = reason
        self.executor.halt()

    def tick(self) -> bool:
        """One control tick: the machine, the end of the episode, then the physics.

        Returns:
            True once the episode is over (the arm at rest and held, or the physics diverged).
        """
        ex, ctx = self.executor, self.ctx
        if self.over:
            return True
        if not ex.done:
            ex.tick()
        for obs in self.observers:
            obs.on_tick(ctx, ex)
        if ex.done and self._ended():
            self.over = True
            return True
        self.diverged = self.loop.tick(ex, self.end_stop)
        if self.diverged:
            self.over = True
            return True
        # the time limit counts the skills' clock: a pause does not use it up
        if ctx.clock - self.clock0 >= self.time_limit_s and not ex.done:
            self.timed_out = ex.violation is None
            ex.halt()
        return False

    def _ended(self) -> bool:
        """The machine is done: is the arm at rest (and the scene settled)?"""
        ex, ctx = self.executor, self.ctx
        if self.end_stop is None:
            abort_stop = ex.stop
            if (
                ex.outcome == "aborted"
                and ex.final_state == SAFE_STOP
                and (abort_stop is not None and not abort_stop.active)
            ):
                return True  # the safe stop brought the arm to rest and held it
            if abort_stop is not None and abort_stop.active:
                self.end_stop = abort_stop  # the time limit fell inside the stop: finish it
            else:
                gentle = SafetyStop(ctx, self.loaded.scenario.physics.safe_stop)
                gentle.start("end of run", gentle=ex.violation is None)
                self.end_stop = gentle
            self.settle_until = ctx.t + (0.0 if ex.violation else SETTLE_S)
        stop = self.end_stop
        return (stop.at_rest and ctx.t >= self.settle_until - 1e-9) or stop.timed_out()

    def _limit_reason(self, final_state: str | None) -> dict[str, Any] | None:
        """Why a run that reached `physics.time_limit_s` ended (`kind: time_limit`), else None:
        the limit, the skills' clock when it was reached and the state it stopped in."""
        if not self.timed_out:
            return None
        detail = self.executor.halt_detail
        return {
            "kind": "time_limit",
            "message": f"the run reached its time limit (physics.time_limit_s = "
            f"{self.time_limit_s:g} s of simulated time) in state {final_state}"
            + (f": {detail}" if detail else ""),
            "value": round(self.ctx.clock - self.clock0, 6),
            "limit": self.time_limit_s,
        }

    def _reason(
        self, outcome: str, final_state: str | None, judged: dict[str, tuple[bool, str]]
    ) -> dict[str, Any] | None:
        """Why the run did not succeed, naming the state and the cause (None: it succeeded,
        or it was halted from outside: the caller says why, engine/runner.py)."""
        ex = self.executor
        if ex.violation is not None:
            reason = ex.violation.to_dict()
            t = round(ex.violation_t if ex.violation_t is not None else self.ctx.t, 6)
            after = [tr["from"] for tr in ex.transitions if tr["t"] >= t]
            reason["state"] = after[0] if after else final_state
            return reason
        limit = self._limit_reason(final_state)
        if limit is not None:
            limit["state"] = final_state
            return limit
        if outcome == "succeeded" or self.halt_reason is not None:
            return None
        if self.diverged:
            return {"kind": "diverged", "state": final_state, "message": self.diverged}
        if ex.fault is not None:
            fault = ex.fault
            return {
                "kind": "skill_error",
                "state": fault.state,
                "message": f"skill {fault.skill} raised {fault.type} in state {fault.state}: "
                f"{fault.message}",
            }
        if ex.outcome == "succeeded":  # the machine ended well; a success check did not hold
            failed = [f"{name}: {text}" for name, (ok, text) in judged.items() if not ok]
            return {
                "kind": "success_check",
                "state": final_state,
                "message": f"the machine ended in {final_state} but a success check failed: "
                + "; ".join(failed),
            }
        last = ex.transitions[-1] if ex.transitions else None
        if last is None:
            return {"kind": "final_state", "state": final_state,
                    "message": f"the machine ended {outcome} in {final_state}"}  # fmt: skip
        origin, why = _cause(ex.transitions)
        detail = f": {why['detail']}" if why is not None else ""
        if why is not None and why is not origin:
            detail = f" (entered on `{why['trigger']}`{detail})"
        relayed = "" if origin is last else f"; {last['from']} ended `{last['trigger']}`"
        return {
            "kind": "final_state",
            "state": origin["from"],
            "message": f"{origin['from']} ended `{origin['trigger']}`{detail}{relayed}, so the "
            f"machine went to {last['to']} ({outcome})",
        }

    # -- the result -----------------------------------------------------------------------
    def result(
        self,
        seed: int,
        wall_time: float,
        faults: list[dict[str, Any]] | None = None,
    ) -> RunResult:
        """What happened: the `run --json` object (a contract: the README's `run --json` example).

        Args:
            seed: The episode's seed.
            wall_time: Wall time of the episode [s].
            faults: Faults injected during the episode (`metrics.faults`).
        """
        ex, ctx, scn = self.executor, self.ctx, self.loaded.scenario
        world, diverged, t0 = ctx.world, self.diverged, self.t0
        outcome = ex.outcome or "failed"
        final_state = ex.final_state
        truth = self.loop.trace_truth
        assert truth is not None  # the loop was bound to this episode's context
        ctx.metrics.update(truth.figures())  # before the checks that read them
        tasks = ctx.tasks.finalize(ctx) if world.parcel_classes and not diverged else None
        judged = (
            evaluate(ctx, scn.success)
            if not diverged
            else dict.fromkeys(scn.success, (False, "physics diverged"))
        )
        success = {name: ok for name, (ok, _) in judged.items()}
        if outcome == "succeeded" and not all(success.values()):
            outcome = "failed"
        metrics: dict[str, Any] = {
            "cycle_time": round(ex.final_t - t0, 6)
            if ex.final_t is not None and not self.timed_out
            else None,
            "max_wrist_force_n": round(math.sqrt(self.loop.max_force_sq), 4),
            "control_ticks": ctx.tick - self.tick0,
        }
        metrics.update(ctx.metrics)
        if tasks is not None:
            metrics.update(task_metrics(tasks, ex.final_t or ctx.t))
            if ctx.tasks.ghost_tasks:  # detections the scheduler served that were no parcel
                metrics["tasks_without_parcel"] = ctx.tasks.ghost_tasks
        if not diverged:
            metrics.update(errors(ctx, scn.success))
        abort_stop = ex.stop
        if ex.violation is not None and abort_stop is not None:
            metrics["abort_t"] = round((ex.violation_t or 0.0) - t0, 6)
            if abort_stop.stop_time_s is not None:
                metrics["stop_time_s"] = round(abort_stop.stop_time_s, 4)
            metrics["stop_distance_mm"] = round(abort_stop.distance_m * 1000.0, 3)
        if faults:
            metrics["faults"] = faults
        if ex.events:
            metrics["events"] = ex.events
            metrics["paused_s"] = round(ctx.clock_offset, 6)
        if ex.pause.pauses:
            metrics["pauses"] = ex.pause.pauses
        metrics["rest_speed_rad_s"] = round(float(np.max(np.abs(ctx.data.qvel[world.arm_dof]))), 5)
        if self.timed_out:
            metrics["time_limit_reached"] = True
            if ex.halt_detail:
                metrics["time_limit_detail"] = f"{final_state}: {ex.halt_detail}"
        if diverged:
            metrics["error"] = diverged
        end_stop = self.end_stop
        if ex.fault is not None and end_stop is not None:
            # a skill raised: no cycle was completed; the controlled stop that brought the arm
            # to rest, as measured
            metrics["cycle_time"] = None
            if end_stop.stop_time_s is not None:
                metrics["stop_time_s"] = round(end_stop.stop_time_s, 4)
            metrics["stop_distance_mm"] = round(end_stop.distance_m * 1000.0, 3)
        return RunResult(
            scenario=scn.name,
            seed=seed,
            outcome=outcome,  # type: ignore[arg-type]
            final_state=final_state,
            reason=self._reason(outcome, final_state, judged),
            sim_time=round(ctx.t - t0, 6),
            wall_time=round(wall_time, 4),
            transitions=ex.transitions,
            metrics=metrics,
            success=success,
            retries=ex.retries,
            success_detail={name: text for name, (_, text) in judged.items()},
            tasks=None if tasks is None else [e.to_dict() for e in tasks],
            error=ex.fault.to_dict() if ex.fault is not None else None,
        )


def _cause(
    transitions: list[dict[str, Any]],
) -> tuple[dict[str, Any], dict[str, Any] | None]:
    """Where the run's last chain of transitions started, and the transition that says why.

    A nested machine's final state hands its outcome up in a transition of its own, at the
    same instant and with no detail (`PICK.GRASP.PLAN` ends `unreachable` with the IK's
    residual, then `PICK.GRASP.UNREACHABLE` and `PICK.UNREACHABLE` pass `unreachable` on):
    the origin is the first of those relays. Its detail says why; without one, the transition
    that entered the origin's state may (a clean-up state such as `PUT_BACK`, entered on
    `wrong_object` with what the hand holds). Returns (origin, the one with the detail or
    None)."""
    i = len(transitions) - 1
    while i > 0 and not transitions[i].get("detail") and not transitions[i].get("retry"):
        prev = transitions[i - 1]
        if prev["to"] != transitions[i]["from"] or prev["t"] != transitions[i]["t"]:
            break
        i -= 1
    origin = transitions[i]
    if origin.get("detail"):
        return origin, origin
    if i > 0 and not origin.get("retry"):
        prev = transitions[i - 1]
        if prev["to"] == origin["from"] and prev.get("detail"):
            return origin, prev
    return origin, None
