"""The executor: runs a machine tree one control tick at a time (the brain).

Each machine level runs as a *region*: a `transitions.Machine` whose triggers are the outcomes
of its states. The active state of a region runs one *activity*: a skill, a nested region
(`machine:` or inline `states:`), or a parallel group of branches (engine/regions.py: the
regions, their activities, timeouts and retries). Here: the guards active in each state,
events, aborts and the safety response, and how the run ends. Guards can abort from any
state, and an e-stop outranks them all: the executor stops every activity and the arm goes
through the controlled stop (the built-in SAFE_STOP state); once it is at rest, the machine's
`on_abort` state runs, or SAFE_STOP holds the pose and the run ends `aborted`.

Events reach the executor through `event()` (a scenario's `events:`, `run --event`, an injected
`estop` fault, a live session): `estop` aborts at once; `pause`, `resume` and the machine's own
events (`events: {stop: GO_HOME}`) take effect at the start of the next control tick.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any, Protocol

from ..guards import get_guard
from ..guards.bank import GuardBank
from ..guards.base import Guard, Violation
from ..guards.easing import Eased
from ..language.loading import MachineNode
from ..language.machine import ABORT, ESTOP, PAUSE, RESUME, SAFE_STOP, guard_entries
from .context import Context
from .pause import PauseControl
from .regions import EPS, Finished, Region, SkillActivity, node_at
from .skill_fault import SkillFault

__all__ = ["Executor", "Stopper", "node_at"]
"""`node_at` is the regions' (engine/regions.py), kept importable from here."""


class Stopper(Protocol):
    """The controlled stop the executor starts on an abort (engine/safety_stop.py)."""

    active: bool
    stop_time_s: float | None
    distance_m: float

    @property
    def at_rest(self) -> bool: ...
    def start(self, reason: str, gentle: bool = False, brake: bool = True) -> None: ...
    def step(self) -> None: ...
    def release(self) -> None: ...
    def timed_out(self) -> bool: ...


class Executor:
    """Drives a machine tree: `start`, then `tick` every control period until `done`.

    Args:
        root: The machine to run.
        ctx: The episode context.
        scenario_guards: Guards active for the whole run.
        new_stop: Makes the controlled stop an abort starts (a `SafetyStop`).
        hold_s: Simulated time the built-in safe stop holds the stopped arm before the run ends.
        response_guards: Guards that stay on during every safety response (the joint
            limits). One of them firing escalates: the `on_abort` response ends, the arm is
            stopped and held.
        stopped_guards: Guards that join them once the arm has been stopped, while the
            `on_abort` response moves it (a hard force ceiling: the braking itself starts from
            the force that fired the abort).
    """

    def __init__(
        self,
        root: MachineNode,
        ctx: Context,
        scenario_guards: list[Guard],
        new_stop: Callable[[], Stopper],
        hold_s: float,
        response_guards: Sequence[Guard] = (),
        stopped_guards: Sequence[Guard] = (),
    ) -> None:
        self.root = root
        self.response_guards = list(response_guards)
        self.stopped_guards = list(stopped_guards)
        self._escalated = False
        """A response guard fired during the safety response: nothing runs but stop and hold."""
        self.ctx = ctx
        self.scenario_guards = (
            [Eased(g) for g in scenario_guards] if root.recovery else scenario_guards
        )
        """A recovery machine's guards are eased: one already violated may only shrink."""
        self.new_stop = new_stop
        self.hold_s = hold_s
        self.region: Region | None = None
        self.transitions: list[dict[str, Any]] = []
        self.retries: dict[str, int] = {}
        self.done = False
        self.outcome: str | None = None
        self.final_state: str | None = None
        self.final_t: float | None = None
        self.violation: Violation | None = None
        self.violation_t: float | None = None
        """Simulated time of the abort [s]."""
        self.stop: Stopper | None = None
        """The controlled stop of the abort (kept once over: its figures go to the metrics)."""
        self.safe_stop_until: float | None = None
        self.active_guards: list[Guard] = []
        self.active_checks: tuple[Callable[[Context], Violation | None], ...] = ()
        """What the physics step calls to check the active guards (one `GuardBank.check`;
        empty while no guard is active)."""
        self.guard_bank: GuardBank | None = None
        """The active guards, in priority order, as the physics step checks them."""
        self._detail: str | None = None
        """Why the state that is ending ended: goes to the next recorded transition."""
        self.halt_detail: str | None = None
        """What the running skill was still waiting for when the time limit ended the run."""
        self._on_abort: str | None = None
        """The `on_abort` state to enter once the arm is at rest (None: the built-in stop)."""
        self.pause = PauseControl(ctx)
        """The skills' clock rate: `pause` slows it to a hold, `resume` back to full speed."""
        self._pending: list[tuple[str, str]] = []
        self.events: list[dict[str, Any]] = []
        """Every event delivered: `{t, event, source}`, plus `ignored` (why) if it had no effect."""
        self.fault: SkillFault | None = None
        """The first skill that raised, if any: the run ends `error` (engine/skill_fault.py)."""
        self._fault_handled = False
        self.reloaded: MachineNode | None = None
        """A machine reloaded while running (engine/reload.py): each level adopts it as it
        enters its next state."""
        self.entry_listeners: list[Callable[[str, int | None], None]] = []
        """Called with (dotted path, retry number or None) as every state is entered, nested
        machines and parallel states included, and SAFE_STOP (a snapshot's break points)."""
        self._guards: dict[tuple[int, str | None], list[Guard]] = {}
        """The guards of each machine level and state, by (`id(level)`, state or None)."""
        self._levels: list[MachineNode] = []
        """The machine levels `_guards` holds guards of."""
        for node in root.nodes():
            self._build_guards(node)

    def __getstate__(self) -> dict:
        # ids do not survive a process: a snapshot (engine/snapshot) keys the guards by level
        state = dict(vars(self))
        state["_guards"] = [
            (node, name, self._guards[(id(node), name)])
            for node in self._levels
            for name in (None, *node.states)
            if (id(node), name) in self._guards
        ]
        return state

    def __setstate__(self, state: dict) -> None:
        guards = state["_guards"]
        vars(self).update(state)
        self._guards = {(id(node), name): listed for node, name, listed in guards}

    # -- guards -------------------------------------------------------------------------
    def _build_guards(self, node: MachineNode) -> None:
        def make(refs) -> list[Guard]:
            out = []
            for _, name, params in guard_entries(refs):
                cls = get_guard(name)
                guard = cls(cls.Params.model_validate(params))
                guard.bind(self.ctx)
                out.append(Eased(guard) if self.root.recovery else guard)
            return out

        self._levels.append(node)
        self._guards[(id(node), None)] = make(node.guards)
        for name, st in node.states.items():
            if st.guards:
                self._guards[(id(node), name)] = make(st.guards)

    def changed(self) -> None:
        """A state changed somewhere: recompute which guards are active."""
        if self.violation is not None or self.region is None:
            # The safety response runs: the guard that fired does not re-fire, but the joint
            # limits and the force ceiling watch the response itself — the ceiling once the
            # arm is stopped (the braking starts from the force that fired the abort).
            guards: list[Guard] = []
            if self.violation is not None and not self._escalated and not self.done:
                guards = list(self.response_guards)
                if self.final_state != SAFE_STOP:  # the on_abort response moves the arm
                    guards += self.stopped_guards
            for guard in guards:
                if guard not in self.active_guards:
                    guard.activate(self.ctx)
            self.active_guards = guards
            self._bind_checks()
            return
        active = list(self.scenario_guards)
        for region in self.region.regions():
            if region.final is not None:
                continue
            active += self._guards.get((id(region.node), None), [])
            active += self._guards.get((id(region.node), region.state), [])
        before = {id(g) for g in self.active_guards}
        entered = False
        for guard in active:
            if id(guard) not in before:
                guard.activate(self.ctx)
                entered = True
        ordered = sorted(active, key=lambda g: -g.priority)
        if not entered and ordered == self.active_guards:
            # the same guards, none (re)activated: their envelopes are what the bank holds
            # (an envelope changes only on activation), so the bank stands
            return
        self.active_guards = ordered
        self._bind_checks()

    def _bind_checks(self) -> None:
        """What the physics step calls: the active guards as one bank (guards/bank.py), which
        tests their envelopes at once and runs their full checks only when a value leaves."""
        self.guard_bank = GuardBank(self.active_guards, self.ctx) if self.active_guards else None
        self.active_checks = (self.guard_bank.check,) if self.guard_bank is not None else ()

    # -- lifecycle ----------------------------------------------------------------------
    @property
    def leaf(self) -> str:
        """Dotted path of the innermost active state (a parallel state names itself)."""
        if self.region is None or self.done or self.final_state == SAFE_STOP:
            return self.final_state or ""
        return self.region.leaf()

    @property
    def paused(self) -> bool:
        """A `pause` is in effect: the skills slow to a stop and hold until `resume`."""
        return self.pause.paused and not self.done

    @property
    def rate(self) -> float:
        """Speed of the skills' clock (1 running, 0 held by a pause; see engine/pause.py)."""
        return self.pause.rate

    def start(self) -> None:
        self.region = Region(self, self.root, "")
        finished = self.region.start(None, None)
        self._check_end(finished)
        self._check_fault()

    def tick(self) -> None:
        """One control tick: timeouts (outer first), then every active skill's step. During
        the controlled stop of an abort nothing runs but the stop. A skill that raised in it
        ends the run `error` (`skill_raised`)."""
        self._tick()
        self._check_fault()

    def _tick(self) -> None:
        if self.done:
            return
        if self._pending:
            pending, self._pending = self._pending, []
            for name, source in pending:
                self._apply(name, source)
            if self.done:
                return
        if self.stop is not None and self.final_state == SAFE_STOP:
            if not (self.stop.at_rest or self.stop.timed_out()):
                return
            if self._on_abort is not None:
                target, self._on_abort = self._on_abort, None
                self.final_state = None
                self.stop.release()  # the response moves the arm: the motors take it back
                assert self.region is not None
                self.region.abort_to(target, SAFE_STOP)
                self._check_end(self.region.final)
                return
            if self.safe_stop_until is None:
                self.safe_stop_until = self.ctx.t + self.hold_s
            if self.ctx.t >= self.safe_stop_until - EPS:
                self._finish("aborted", SAFE_STOP)
            return
        assert self.region is not None
        if not self.pause.tick():  # held by a pause: no skill steps, no timeout runs
            return
        self._check_end(self.region.tick())

    def event(self, name: str, source: str = "") -> bool:
        """Deliver the event `name`: `estop` aborts at once; `pause`, `resume` and the
        machine's own events take effect at the start of the next control tick.

        Args:
            name: A built-in event or one of the top-level machine's `events:`.
            source: Who sent it (for the log and the result's `metrics.events`).

        Returns:
            False if the machine does not know the event (nothing happens).
        """
        if name == ESTOP:
            self.events.append({"t": round(self.ctx.t, 6), "event": name, "source": source})
            self.estop(source)
            return True
        if name not in (PAUSE, RESUME) and name not in self.root.events:
            return False
        self._pending.append((name, source))
        return True

    def _apply(self, name: str, source: str) -> None:
        ctx = self.ctx
        rec: dict[str, Any] = {"t": round(ctx.t, 6), "event": name, "source": source}
        self.events.append(rec)
        ignored = None
        if self.violation is not None:
            ignored = "the safety response to an abort runs"
        elif name == PAUSE:
            if self.pause.paused:
                ignored = "already paused"
            else:
                self.pause.pause()
        elif name == RESUME:
            if not self.pause.paused:
                ignored = "not paused"
            else:
                self.pause.resume()
        else:
            assert self.region is not None
            ctx.log("event", f"{name}: preempting {self.leaf} -> {self.root.events[name]}")
            self._check_end(self.region.preempt(name, self.leaf))
        if ignored is not None:
            rec["ignored"] = ignored
        ctx.log("event", f"event {name} ({source})" + (f" ignored: {ignored}" if ignored else ""))

    def abort(self, violation: Violation) -> None:
        """A guard fired: stop every activity, brake the arm to rest (SAFE_STOP), then go to
        `on_abort` or hold and end. Later violations are ignored; an e-stop is not."""
        self._abort(violation)
        self._check_fault()  # a skill's `stop` that raised on the way

    def _abort(self, violation: Violation) -> None:
        if self.done or self.region is None:
            return
        if self.violation is not None and (
            violation.guard != ESTOP or self.violation.guard == ESTOP
        ):
            self._escalate(violation)
            return
        self.violation = violation
        self.violation_t = self.ctx.t
        self._log_violation(violation, f"{violation.guard}: {violation.message}")
        self._on_abort = self.root.on_abort if violation.guard != ESTOP else None
        self.pause.cancel()  # the safety response is never paused
        self._enter_safe_stop(violation, ESTOP if violation.guard == ESTOP else ABORT)
        self.changed()

    def trip(self, guard: str, message: str, value: Any = None, limit: Any = None) -> None:
        """A safety function outside the guards fired (a live session's watchdog): abort
        as a guard would, with `guard` as the reason."""
        self.abort(Violation(guard, message, value, limit))

    def _escalate(self, violation: Violation) -> None:
        """A response guard fired during the safety response: end the `on_abort` response,
        stop the arm (again, if it was moving) and hold it until the run ends `aborted`."""
        if self._escalated or self.done:
            return
        self._escalated = True
        msg = f"{violation.guard} during the safety response: {violation.message}"
        self._log_violation(violation, msg)
        self._on_abort = None
        if self.final_state != SAFE_STOP and self.region is not None:
            self._enter_safe_stop(violation, ABORT)
        self.changed()

    def _log_violation(self, violation: Violation, message: str) -> None:
        self.ctx.log(
            "violation",
            message,
            level="ERROR",
            guard=violation.guard,
            value=violation.value,
            limit=violation.limit,
        )

    def _enter_safe_stop(self, violation: Violation, trigger: str) -> None:
        """Leave the running state for SAFE_STOP and start the controlled stop."""
        assert self.region is not None
        leaf = self.leaf
        self.region.stop()
        for listener in self.entry_listeners:
            listener(SAFE_STOP, None)
        self.record(leaf, SAFE_STOP, trigger)
        self.final_state = SAFE_STOP
        self.safe_stop_until = None
        self.stop = self.new_stop()
        # the brakes hold the stopped arm unless an on_abort response takes it over
        self.stop.start(f"{violation.guard}: {violation.message}", brake=self._on_abort is None)

    def estop(self, source: str) -> None:
        """An emergency stop: outranks every guard and any `on_abort` response."""
        self.abort(Violation(ESTOP, f"emergency stop ({source})", None, None))

    def halt(self) -> None:
        """End the run where it is (the time limit): stop every activity. Ends `aborted` if a
        guard had fired, else `failed`; the caller brings the arm to rest."""
        if self.done:
            return
        leaf = self.leaf
        if self.region is not None:
            self.explain(self.region, "time limit reached", leaf)
            self.halt_detail, self._detail = self._detail, None
            self.region.stop()
        self._finish("aborted" if self.violation is not None else "failed", leaf)

    def explain(self, activity: object, what: str, path: str | None = None) -> None:
        """Log why a state ends with a failure outcome or a timeout (`what`), with the
        running skill's explanation; the next recorded transition carries it as `detail`."""
        leaf = activity.leaf() if isinstance(activity, (SkillActivity, Region)) else None
        inner = activity
        while isinstance(inner, Region) and inner.activity is not None:
            inner = inner.activity  # a nested machine timed out: ask its running skill
        detail = inner.detail() if isinstance(inner, SkillActivity) else None
        if detail is None and path is not None and leaf is not None and leaf != path:
            detail = f"still in {leaf}"
        self._detail = detail
        at = path or leaf or self.leaf
        self.ctx.log(
            "timeout" if what.startswith("timeout") else "outcome",
            f"{at}: {what}" + (f": {detail}" if detail else ""),
        )

    def record(self, src: str, dst: str, trigger: str, retry: int | None = None) -> None:
        """Append a transition to the result (and tell the listeners)."""
        rec: dict[str, Any] = {
            "t": round(self.ctx.t, 6),
            "from": src,
            "to": dst,
            "trigger": trigger,
        }
        if retry:
            rec["retry"] = retry
        if self._detail is not None:
            rec["detail"], self._detail = self._detail, None
        self.transitions.append(rec)
        self.ctx.log("transition", f"{src} -> {dst} ({trigger})", transition=rec)

    # -- internals ----------------------------------------------------------------------
    def _check_end(self, finished: Finished | None) -> None:
        if finished is None:
            return
        outcome, path = finished
        if self.violation is not None:
            self._finish("aborted", path)
        else:
            self._finish("succeeded" if outcome == "succeeded" else "failed", path)

    def skill_raised(self, fault: SkillFault) -> None:
        """A skill's own code raised (its activity caught it): the first fault is the run's;
        the run ends `error` when the executor's current call is over (`_check_fault`)."""
        self.ctx.log("error", fault.line(), level="ERROR", skill=fault.skill, where=fault.where)
        if self.fault is None:
            self.fault = fault

    def _check_fault(self) -> None:
        """End the run `error` if a skill raised: every activity is stopped (their `stop`s
        leave setpoints behind; one that raises too is logged) and the runner brings the arm
        to rest with the controlled stop, as at any end of a run, and holds it."""
        if self.fault is None or self._fault_handled:
            return
        self._fault_handled = True
        if self.done:  # a skill's `stop` raised as the run ended
            self.outcome, self.final_state = "error", self.fault.state
            return
        if self.region is not None and self.final_state != SAFE_STOP:
            self.region.stop()
        self._finish("error", self.fault.state)

    def _finish(self, outcome: str, state: str) -> None:
        self.done = True
        if self.fault is not None:  # a raising skill outranks how the machine ended
            outcome, state = "error", self.fault.state
        self.outcome = outcome
        self.final_state = state
        self.final_t = self.ctx.t
        self.active_guards = []
        self.guard_bank = None
        self.active_checks = ()
