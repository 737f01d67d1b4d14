"""The machine levels an executor runs (engine/executor.py drives them, one control tick at a
time).

Each machine level runs as a *region*: a `transitions.Machine` whose triggers are the outcomes
of its states. The active state of a region runs one *activity*: a skill (`SkillActivity`), a
nested region (`machine:` or inline `states:`), or a parallel group of branches
(`ParallelActivity`). Timeouts of states and of single-skill branches are kept here, retries
too; guards, events, aborts and the end of the run are the executor's (`Driver` is what a
region asks of it).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

import transitions
from pydantic import ValidationError

from ..exceptions import ConfigError, SkillError
from ..language.loading import MachineNode
from ..language.machine import ABORT, BranchSpec, StateSpec
from ..language.validation import branch_outcomes, state_outcomes
from ..skills import Skill, get_skill
from .blackboard import BlackboardError
from .context import Context
from .skill_fault import SkillFault

__all__ = ["Driver", "Finished", "ParallelActivity", "Region", "SkillActivity", "node_at"]

EPS = 1e-9
"""Slack on simulated-time comparisons [s] (a timeout of 0.3 s ends at the tick of 0.3 s)."""

Finished = tuple[str, str]
"""(outcome, dotted path of the leaf state it came from)."""

_MAX_INSTANT_ENTRIES = 20_000
"""States one tick may enter through nested machines that finish as they start (retries
included; `retry` is at most 10,000): beyond it the machine loops without time passing."""


@dataclass(frozen=True)
class _Instant:
    """A nested machine finished the moment it started, with `outcome` in state `src`."""

    outcome: str
    src: str


class Activity(Protocol):
    """What a state runs. An activity whose `tick` reports it finished has stopped itself."""

    def tick(self) -> Finished | None: ...
    def stop(self) -> None: ...
    def leaf(self) -> str: ...
    def regions(self) -> list[Region]: ...


class Driver(Protocol):
    """What a region and its activities ask of the executor that drives them."""

    ctx: Context
    root: MachineNode
    retries: dict[str, int]
    """Retries taken, by state's dotted path (the result's `retries`)."""
    reloaded: MachineNode | None
    entry_listeners: list[Callable[[str, int | None], None]]

    def changed(self) -> None: ...
    def record(self, src: str, dst: str, trigger: str, retry: int | None = None) -> None: ...
    def explain(self, activity: object, what: str, path: str | None = None) -> None: ...
    def skill_raised(self, fault: SkillFault) -> None: ...


class _Model:
    """The object `transitions` keeps the state on (kept bare so triggers cannot clash)."""

    state: str
    trigger: Callable[..., bool]  # added by transitions.Machine


def _make_skill(ex: Driver, node: MachineNode, at: tuple, spec: StateSpec | BranchSpec) -> Skill:
    """The state's skill, its parameters read from the blackboard now (a value that does not
    fit is a ConfigError located at the state's `with:`)."""
    assert spec.skill is not None
    cls = get_skill(spec.skill)
    try:
        params = cls.Params.model_validate(ex.ctx.blackboard.resolve(spec.with_))
    except BlackboardError as exc:
        raise ConfigError(
            [node.source.diag((*at, "with"), f"at t={ex.ctx.t:.3f} s: {exc}")], during_run=True
        ) from None
    except ValidationError as exc:  # a value read from the blackboard: each error, located
        raise ConfigError(
            [
                node.source.diag(
                    (*at, "with", *err["loc"]),
                    f"at t={ex.ctx.t:.3f} s: {err['msg']}, got {err.get('input')!r}",
                )
                for err in exc.errors(include_url=False)
            ],
            during_run=True,
        ) from None
    return cls(params)  # a skill whose constructor raises: see SkillActivity


def _start_skill(ex: Driver, node: MachineNode, at: tuple, skill: Skill) -> None:
    try:
        skill.start(ex.ctx)
    except SkillError as exc:
        raise ConfigError(
            [node.source.diag(at, f"at t={ex.ctx.t:.3f} s: {exc}")], during_run=True
        ) from None


def _step_skill(ex: Driver, node: MachineNode, at: tuple, skill: Skill) -> str | None:
    try:
        outcome = skill.step(ex.ctx)
    except SkillError as exc:
        raise ConfigError(
            [node.source.diag(at, f"at t={ex.ctx.t:.3f} s: {exc}")], during_run=True
        ) from None
    if outcome is not None and outcome not in type(skill).outcomes:
        raise SkillError(
            f"skill {skill.name!r} returned {outcome!r}, which it does not declare"
            f" (valid: {', '.join(type(skill).outcomes)})"
        )
    return outcome


class SkillActivity:
    """The skill of a state, or a single-skill parallel branch (with its own timeout).

    Whatever the skill's own code raises (but a `SkillError`, a misuse said as a located
    ConfigError) is caught here and handed to the executor as a `SkillFault`; the activity
    then stands still (its `tick` reports nothing more) and the executor ends the run with
    outcome `error` once the current call is over.
    """

    def __init__(
        self,
        ex: Driver,
        node: MachineNode,
        at: tuple,
        path: str,
        spec: StateSpec | BranchSpec,
        timeout: float | None = None,
    ) -> None:
        self.ex, self.node, self.at, self.path = ex, node, at, path
        self.failed = False
        """The skill raised: it is not called again (but for `stop`)."""
        self.skill: Skill | None = None
        self.cls = get_skill(spec.skill or "")
        try:
            self.skill = _make_skill(ex, node, at, spec)
        except ConfigError:
            raise
        except Exception as exc:  # the skill's constructor: its own code
            self._raised(exc, "__init__")
        self.timeout = timeout
        self.t0 = ex.ctx.clock

    def _raised(self, exc: Exception, method: str) -> None:
        self.failed = True
        self.ex.skill_raised(SkillFault.of(self.cls, method, self.path, self.ex.ctx.t, exc))

    def start(self) -> None:
        if self.skill is None or self.failed:
            return
        try:
            _start_skill(self.ex, self.node, self.at, self.skill)
        except ConfigError:
            raise
        except Exception as exc:  # the skill's own code
            self._raised(exc, "start")

    def tick(self) -> Finished | None:
        if self.skill is None or self.failed:
            return None  # the executor ends the run at the end of this call
        if self.timeout is not None and self.ex.ctx.clock - self.t0 >= self.timeout - EPS:
            self.ex.explain(self, f"timeout after {self.timeout} s")
            self.stop()
            return "timeout", self.path
        try:
            outcome = _step_skill(self.ex, self.node, self.at, self.skill)
        except ConfigError:
            raise
        except Exception as exc:  # the skill's own code
            self._raised(exc, "step")
            return None
        if outcome is None:
            return None
        kind = type(self.skill)
        if outcome != kind.outcomes[0] or outcome in getattr(kind, "explained", ()):
            self.ex.explain(self, outcome)
        else:
            self.ex.ctx.log("outcome", f"{self.path}: {outcome}")
        self.stop()
        return outcome, self.path

    def detail(self) -> str | None:
        """The skill's own account of why it is ending (its `explain`)."""
        if self.skill is None or self.failed:
            return None
        try:
            return self.skill.explain(self.ex.ctx)
        except Exception as exc:  # the skill's own code
            self._raised(exc, "explain")
            return None

    def stop(self) -> None:
        if self.skill is None:
            return
        try:
            self.skill.stop(self.ex.ctx)
        except Exception as exc:  # the skill's own code: the stop goes on
            self._raised(exc, "stop")

    def leaf(self) -> str:
        return self.path

    def regions(self) -> list[Region]:
        return []


class ParallelActivity:
    """Branches ticked side by side; `rule` decides when the state ends and with what."""

    def __init__(self, ex: Driver, region: Region, name: str, spec: StateSpec) -> None:
        self.ex, self.path, self.rule = ex, region.prefix + name, spec.rule
        self.branches: dict[str, Region | SkillActivity] = {}
        self.success: dict[str, str] = {}
        self.done: dict[str, str] = {}
        node = region.node
        for bname, branch in node.branches[name].items():
            at = (*node.at, "states", name, "parallel", bname)
            bpath = f"{self.path}.{bname}"
            outcomes = branch_outcomes(branch)
            self.success[bname] = outcomes[0] if outcomes else ""
            if isinstance(branch, MachineNode):
                self.branches[bname] = Region(ex, branch, bpath + ".")
            else:
                self.branches[bname] = SkillActivity(ex, node, at, bpath, branch, branch.timeout)

    def start(self, src: str) -> None:
        for activity in self.branches.values():
            if isinstance(activity, Region):
                activity.start(src, "parallel")
            else:
                for listener in self.ex.entry_listeners:  # a single-skill branch is entered
                    listener(activity.path, None)
                activity.start()

    def tick(self) -> Finished | None:
        for bname, activity in self.branches.items():
            if bname in self.done:
                continue
            finished = activity.tick()
            if finished is None:
                continue
            outcome = finished[0]
            self.done[bname] = outcome
            ok = outcome == self.success[bname]
            self.ex.ctx.log("outcome", f"{self.path}.{bname}: {outcome}")
            if self.rule == "first":
                return self._end(outcome)
            if self.rule == "all" and not ok:
                return self._end("failed")
            if self.rule == "any" and ok:
                return self._end("succeeded")
        if len(self.done) == len(self.branches):
            return self._end("succeeded" if self.rule == "all" else "failed")
        return None

    def _end(self, outcome: str) -> Finished:
        for bname, activity in self.branches.items():
            if bname not in self.done:
                activity.stop()  # the other branches are stopped cleanly
        return outcome, self.path

    def stop(self) -> None:
        for bname, activity in self.branches.items():
            if bname not in self.done:
                activity.stop()

    def leaf(self) -> str:
        return self.path

    def regions(self) -> list[Region]:
        return [a for b, a in self.branches.items() if isinstance(a, Region) and b not in self.done]


class Region:
    """One running machine level."""

    def __init__(self, ex: Driver, node: MachineNode, prefix: str) -> None:
        self.ex, self.node, self.prefix = ex, node, prefix
        self.model = _Model()
        self.fsm = self._machine(node, node.initial)
        self.activity: Activity | None = None
        self.entered_t = ex.ctx.clock
        self.retries: dict[str, int] = {}
        self.final: Finished | None = None

    def _machine(self, node: MachineNode, initial: str) -> transitions.Machine:
        """The `transitions` machine of `node`'s states and edges, in state `initial`."""
        edges: list[list[str]] = []
        for name, st in node.states.items():
            edges += [[outcome, name, target] for outcome, target in st.transitions.items()]
            edges.append(["retry", name, name])
        if node.top and node.on_abort is not None:
            edges.append([ABORT, "*", node.on_abort])
        if node.top:
            edges += [[event, "*", target] for event, target in node.events.items()]
        return transitions.Machine(
            model=self.model,
            states=list(node.states),
            transitions=edges,
            initial=initial,
            auto_transitions=False,
        )

    def _adopt(self, root: MachineNode) -> None:
        """A reloaded machine file (engine/reload.py): this level takes its new definition
        as it enters a state (the state that ran finished as it was defined when entered)."""
        node = node_at(root, self.prefix)
        if node is None or node is self.node or self.model.state not in node.states:
            return
        state = self.model.state
        self.node = node
        self.model = _Model()
        self.fsm = self._machine(node, state)
        if not self.prefix:
            self.ex.root = root
        level = self.prefix.rstrip(".") or "the top level"
        self.ex.ctx.log("reload", f"{level}: the reloaded definition from {self.prefix}{state} on")

    @property
    def state(self) -> str:
        return self.model.state

    @property
    def spec(self) -> StateSpec:
        return self.node.states[self.model.state]

    def leaf(self) -> str:
        return self.activity.leaf() if self.activity is not None else self.prefix + self.state

    def regions(self) -> list[Region]:
        inner = self.activity.regions() if self.activity is not None else []
        return [self, *(r for region in inner for r in region.regions())]

    def start(
        self, src: str | None, trigger: str | None, retry: int | None = None
    ) -> Finished | None:
        return self._enter(src, trigger, retry)

    def stop(self) -> None:
        if self.activity is not None:
            self.activity.stop()
            self.activity = None

    def tick(self) -> Finished | None:
        if self.final is not None:
            return self.final
        st = self.spec
        if st.timeout is not None and self.ex.ctx.clock - self.entered_t >= st.timeout - EPS:
            self.ex.explain(
                self.activity, f"timeout after {st.timeout} s", self.prefix + self.state
            )
            leaf = self.leaf()
            self.stop()
            return self._outcome("timeout", leaf)
        if self.activity is None:
            return None
        finished = self.activity.tick()
        if finished is None:
            return None
        self.activity = None
        return self._outcome(*finished)

    def abort_to(self, state: str, src: str) -> None:
        """Stop what runs and enter `state` (the machine's `on_abort`), once the arm stopped."""
        self.stop()
        self.model.trigger(ABORT)
        assert self.state == state
        self._enter(src, "stopped")

    def preempt(self, event: str, src: str) -> Finished | None:
        """Stop what runs and enter the state the machine maps `event` to."""
        self.stop()
        self.final = None
        self.model.trigger(event)
        return self._enter(src, event)

    def _outcome(self, outcome: str, src: str) -> Finished | None:
        trigger, retry = self._next(outcome)
        return self._enter(src, trigger, retry)

    def _next(self, outcome: str) -> tuple[str, int | None]:
        """Take the transition (or the retry) for `outcome`; returns the entry's trigger and
        retry number."""
        st = self.spec
        path = self.prefix + self.state
        outcomes = state_outcomes(self.node, self.state)
        failures = st.retry_on if st.retry_on is not None else outcomes[1:]
        used = self.retries.get(self.state, 0)
        if st.retry and outcome in failures and used < st.retry:
            self.retries[self.state] = used + 1
            self.ex.retries[path] = self.ex.retries.get(path, 0) + 1
            self.ex.ctx.log("retry", f"{path}: {outcome}, retry {used + 1} of {st.retry}")
            self.model.trigger("retry")
            return outcome, used + 1
        self.model.trigger(outcome)
        return outcome, None

    def _enter(
        self, src: str | None, trigger: str | None, retry: int | None = None
    ) -> Finished | None:
        """Enter the current state. Nested machines that finish the moment they start are
        followed in a loop, not by recursion: a `retry: 10000` on one costs no stack."""
        for _ in range(_MAX_INSTANT_ENTRIES):
            finished = self._enter_once(src, trigger, retry)
            if not isinstance(finished, _Instant):
                return finished
            outcome, src = finished.outcome, finished.src
            trigger, retry = self._next(outcome)
        raise ConfigError(
            [
                self.node.source.diag(
                    (*self.node.at, "states", self.state),
                    f"{_MAX_INSTANT_ENTRIES} states entered without simulated time passing "
                    "(nested machines that finish as they start, in a loop): give the loop a "
                    "state that takes time, or an exit",
                )
            ],
            during_run=True,
        )

    def _enter_once(
        self, src: str | None, trigger: str | None, retry: int | None
    ) -> Finished | _Instant | None:
        if self.ex.reloaded is not None:
            self._adopt(self.ex.reloaded)
        ex, name, st = self.ex, self.state, self.spec
        path = self.prefix + name
        self.entered_t = ex.ctx.clock
        for listener in ex.entry_listeners:
            listener(path, retry)
        at = (*self.node.at, "states", name)
        if st.states is None and st.machine is None and src is not None:
            ex.record(src, path, trigger or "", retry)
        if st.final is not None:
            self.final = (st.final, path)
            ex.changed()
            return self.final
        if st.skill is not None:
            activity = SkillActivity(ex, self.node, at, path, st)
            self.activity = activity
            ex.changed()
            activity.start()
            return None
        if st.parallel is not None:
            group = ParallelActivity(ex, self, name, st)
            self.activity = group
            group.start(path)
            ex.changed()
            return None
        child = Region(ex, self.node.children[name], path + ".")
        self.activity = child
        finished = child.start(src, trigger, retry)
        ex.changed()
        if finished is not None:  # the nested machine starts in a final state
            self.activity = None
            return _Instant(*finished)
        return None


def node_at(root: MachineNode, prefix: str) -> MachineNode | None:
    """The machine level a region with dotted `prefix` runs (`PICK.`, `WATCHED.watch.`) in the
    tree `root`; None if the tree has no such level."""
    node: MachineNode | None = root
    parts = prefix.split(".")[:-1]
    i = 0
    while node is not None and i < len(parts):
        name = parts[i]
        branches = node.branches.get(name)
        if branches is not None and i + 1 < len(parts) and parts[i + 1] in branches:
            branch = branches[parts[i + 1]]
            node, i = (branch if isinstance(branch, MachineNode) else None), i + 2
        else:
            node, i = node.children.get(name), i + 1
    return node
