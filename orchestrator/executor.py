"""The executor: runs a machine tree one control tick at a time (the brain).

Each machine level is a `transitions.Machine` whose triggers are the outcomes of its states;
nested machines run as a stack of frames. Guards can abort from any state.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import transitions
from pydantic import ValidationError

from .blackboard import BlackboardError
from .context import Context
from .diagnostics import Diagnostic
from .exceptions import ConfigError, SkillError
from .guard import Guard, Violation
from .guards import get_guard
from .loading import MachineNode
from .machine import StateSpec, guard_entries
from .skills import Skill, get_skill
from .validation import state_outcomes

__all__ = ["ABORT", "SAFE_STOP", "Executor"]

ABORT = "abort"
SAFE_STOP = "SAFE_STOP"
"""The built-in state a guard violation leads to when the machine names no `on_abort`."""


class _Model:
    """The object `transitions` keeps the state on (kept bare so triggers cannot clash)."""

    state: str


@dataclass
class _Frame:
    node: MachineNode
    prefix: str
    model: _Model
    fsm: transitions.Machine
    entered_t: float = 0.0
    skill: Skill | None = None
    child: _Frame | None = None
    retries: dict[str, int] = field(default_factory=dict)

    @property
    def state(self) -> str:
        return self.model.state

    @property
    def spec(self) -> StateSpec:
        return self.node.states[self.model.state]


def _make_frame(node: MachineNode, prefix: str, with_abort: bool) -> _Frame:
    model = _Model()
    names = list(node.states)
    edges: list[list[str]] = []
    for name, st in node.states.items():
        for outcome, target in st.transitions.items():
            edges.append([outcome, name, target])
        edges.append(["retry", name, name])
    if with_abort and node.on_abort is not None:
        edges.append([ABORT, "*", node.on_abort])
    fsm = transitions.Machine(
        model=model,
        states=names,
        transitions=edges,
        initial=node.initial,
        auto_transitions=False,
        send_event=False,
    )
    return _Frame(node, prefix, model, fsm)


class Executor:
    """Drives a machine tree: `start`, then `tick` every control period until `done`.

    Args:
        root: The machine to run.
        ctx: The episode context.
        scenario_guards: Guards active for the whole run.
        safe_stop_s: Simulated time the built-in safe stop holds the pose before the run ends.
    """

    def __init__(
        self, root: MachineNode, ctx: Context, scenario_guards: list[Guard], safe_stop_s: float
    ) -> None:
        self.root = root
        self.ctx = ctx
        self.scenario_guards = scenario_guards
        self.safe_stop_s = safe_stop_s
        self.frames: list[_Frame] = []
        self.transitions: list[dict[str, Any]] = []
        self.retries: dict[str, int] = {}
        self.done = False
        self.outcome: str | None = None
        self.final_state: str | None = None
        self.final_t: float | None = None
        self.violation: Violation | None = None
        self.safe_stop_until: float | None = None
        self.active_guards: list[Guard] = []
        self._guards: dict[tuple[int, str | None], list[Guard]] = {}
        self._build_guards(root)

    # -- guards -------------------------------------------------------------------------
    def _build_guards(self, node: MachineNode) -> None:
        def make(refs) -> list[Guard]:
            out = []
            for _, name, params in guard_entries(refs):
                cls = get_guard(name)
                guard = cls(cls.Params.model_validate(params))
                guard.bind(self.ctx)
                out.append(guard)
            return out

        self._guards[(id(node), None)] = make(node.guards)
        for name, st in node.states.items():
            if st.guards:
                self._guards[(id(node), name)] = make(st.guards)
        for child in node.children.values():
            self._build_guards(child)

    def _refresh_guards(self) -> None:
        if self.violation is not None:
            self.active_guards = []  # the safety response runs; do not re-fire
            return
        active = list(self.scenario_guards)
        for frame in self.frames:
            active += self._guards.get((id(frame.node), None), [])
            active += self._guards.get((id(frame.node), frame.state), [])
        self.active_guards = sorted(active, key=lambda g: -g.priority)

    # -- lifecycle ----------------------------------------------------------------------
    @property
    def leaf(self) -> str:
        """Dotted path of the innermost active state."""
        if not self.frames:
            return self.final_state or ""
        f = self.frames[-1]
        return f.prefix + f.state

    def start(self) -> None:
        frame = _make_frame(self.root, "", with_abort=True)
        self.frames = [frame]
        self._enter(frame, None, None)

    def tick(self) -> None:
        """One control tick: timeouts, then the active skill's step."""
        if self.done:
            return
        ctx = self.ctx
        if self.safe_stop_until is not None:
            if ctx.t >= self.safe_stop_until - 1e-9:
                self._finish("aborted", SAFE_STOP)
            return
        for frame in list(self.frames):  # outer timeouts win
            st = frame.spec
            if st.timeout is not None and ctx.t - frame.entered_t >= st.timeout - 1e-9:
                ctx.log("timeout", f"{frame.prefix}{frame.state}: timeout after {st.timeout} s")
                self._outcome(frame, "timeout")
                return
        frame = self.frames[-1]
        if frame.skill is None:
            return
        try:
            outcome = frame.skill.step(ctx)
        except SkillError as exc:
            raise ConfigError([runtime_error(frame.node, frame.state, str(exc))]) from None
        if outcome is not None:
            if outcome not in type(frame.skill).outcomes:
                raise SkillError(
                    f"skill {frame.skill.name!r} returned {outcome!r}, which it does not declare"
                    f" (valid: {', '.join(type(frame.skill).outcomes)})"
                )
            ctx.log("outcome", f"{frame.prefix}{frame.state}: {outcome}")
            self._outcome(frame, outcome)

    def abort(self, violation: Violation) -> None:
        """A guard fired: stop everything and go to `on_abort` or the built-in safe stop."""
        if self.violation is not None or self.done:
            return
        ctx = self.ctx
        self.violation = violation
        ctx.log(
            "violation",
            f"{violation.guard}: {violation.message}",
            level="ERROR",
            guard=violation.guard,
            value=violation.value,
            limit=violation.limit,
        )
        leaf = self.leaf
        self._stop_from(0)
        root = self.frames[0]
        self.frames = [root]
        if self.root.on_abort is not None:
            root.model.trigger(ABORT)
            self._record(leaf, root.state, ABORT)
            self._enter(root, None, None, record=False)
        else:
            self._record(leaf, SAFE_STOP, ABORT)
            self.frames = []
            ctx.controller.hold(ctx.q.copy())
            self.safe_stop_until = ctx.t + self.safe_stop_s
            self.final_state = SAFE_STOP
            self._refresh_guards()

    # -- internals ----------------------------------------------------------------------
    def _record(self, src: str, dst: str, trigger: str, **extra: Any) -> None:
        rec = {"t": round(self.ctx.t, 6), "from": src, "to": dst, "trigger": trigger, **extra}
        self.transitions.append(rec)
        self.ctx.log("transition", f"{src} -> {dst} ({trigger})", transition=rec)

    def _stop_from(self, index: int) -> None:
        for frame in reversed(self.frames[index:]):
            if frame.skill is not None:
                frame.skill.stop(self.ctx)
                frame.skill = None
            frame.child = None

    def _outcome(self, frame: _Frame, outcome: str, leaf: str | None = None) -> None:
        index = self.frames.index(frame)
        leaf = leaf or self.leaf
        self._stop_from(index)
        del self.frames[index + 1 :]
        st = frame.spec
        path = frame.prefix + frame.state
        outcomes = state_outcomes(frame.node, frame.state)
        failures = st.retry_on if st.retry_on is not None else outcomes[1:]
        used = frame.retries.get(frame.state, 0)
        if st.retry and outcome in failures and used < st.retry:
            frame.retries[frame.state] = used + 1
            self.retries[path] = self.retries.get(path, 0) + 1
            self.ctx.log("retry", f"{path}: {outcome}, retry {used + 1} of {st.retry}")
            frame.model.trigger("retry")
            self._enter(frame, leaf, outcome, retry=used + 1)
            return
        frame.model.trigger(outcome)
        self._enter(frame, leaf, outcome)

    def _enter(
        self,
        frame: _Frame,
        src: str | None,
        trigger: str | None,
        record: bool = True,
        retry: int | None = None,
    ) -> None:
        ctx = self.ctx
        name = frame.state
        st = frame.spec
        frame.entered_t = ctx.t
        if st.states is None and st.machine is None and record and src is not None:
            extra = {"retry": retry} if retry else {}
            self._record(src, frame.prefix + name, trigger or "", **extra)
        if st.final is not None:
            if len(self.frames) == 1:
                self.frames = []
                outcome = "aborted" if self.violation else (
                    "succeeded" if st.final == "succeeded" else "failed"
                )
                self._finish(outcome, name)
            else:
                parent = self.frames[-2]
                ctx.log("outcome", f"{parent.prefix}{parent.state}: {st.final}")
                self.frames.pop()
                self._outcome(parent, st.final, leaf=frame.prefix + name)
            return
        if st.skill is not None:
            frame.skill = self._make_skill(frame, st)
            self._refresh_guards()
            try:
                frame.skill.start(ctx)
            except SkillError as exc:
                raise ConfigError([runtime_error(frame.node, name, str(exc))]) from None
            return
        child_node = frame.node.children[name]
        child = _make_frame(child_node, f"{frame.prefix}{name}.", with_abort=False)
        frame.child = child
        self.frames.append(child)
        child.entered_t = ctx.t
        self._enter(child, src if record else None, trigger, record=record, retry=retry)

    def _make_skill(self, frame: _Frame, st: StateSpec) -> Skill:
        assert st.skill is not None
        cls = get_skill(st.skill)
        at = (*frame.node.at, "states", frame.state, "with")
        try:
            params = cls.Params.model_validate(self.ctx.blackboard.resolve(st.with_))
        except (BlackboardError, ValidationError) as exc:
            raise ConfigError([frame.node.source.diag(at, f"at t={self.ctx.t:.3f} s: {exc}")]) from None
        return cls(params)

    def _finish(self, outcome: str, state: str) -> None:
        self.done = True
        self.outcome = outcome
        self.final_state = state
        self.final_t = self.ctx.t
        self.active_guards = []


def runtime_error(node: MachineNode, state: str, message: str) -> Diagnostic:
    """A diagnostic for a problem only visible while running (e.g. an unknown target)."""
    return node.source.diag((*node.at, "states", state), message)
