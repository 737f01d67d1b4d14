"""Load machines (with their nested and included machines) into a tree the executor runs."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from pydantic import ValidationError

from ..exceptions import ConfigError
from .diagnostics import Diagnostic
from .includes import resolve_include
from .limits import InputLimits, current_limits
from .machine import BlackboardKey, BranchSpec, GuardRef, MachineSpec, StateSpec
from .pydantic_errors import diagnostics_from_validation
from .yamlio import SourceMap, load_yaml

__all__ = ["Branch", "MachineNode", "initial_values", "load_machine_file"]


@dataclass
class MachineNode:
    """One machine level, ready to run: its states and, per state, what runs there.

    Attributes:
        name: Machine name (the file's `name:`, or the state name for inline machines).
        initial: The initial state.
        states: State name -> spec.
        blackboard: Declared keys and defaults of this level.
        types: Declared type of each key (`any` for the short form `key: default`).
        guards: Machine-level guards.
        on_abort: State entered after a guard fires (None: the built-in safe stop).
        events: Event name -> state it preempts into (`events:`; top-level machines only).
        inputs: Key -> its `input:` flag, for the keys this level declares with one.
        recovery: A recovery machine (`recovery: true`; top-level machines only).
        children: State name -> nested machine for `machine:` and inline `states:`.
        branches: Parallel state name -> branch name -> a nested machine, or the branch spec
            itself for a single-skill branch.
        source: Where this machine's keys are (for messages).
        at: Path of this machine's mapping inside its file.
    """

    name: str
    initial: str
    states: dict[str, StateSpec]
    blackboard: dict[str, Any]
    guards: list[GuardRef]
    on_abort: str | None
    source: SourceMap
    at: tuple = ()
    children: dict[str, MachineNode] = field(default_factory=dict)
    branches: dict[str, dict[str, Branch]] = field(default_factory=dict)
    types: dict[str, str] = field(default_factory=dict)
    top: bool = True
    events: dict[str, str] = field(default_factory=dict)
    inputs: dict[str, bool] = field(default_factory=dict)
    recovery: bool = False

    def outcomes(self) -> list[str]:
        """The outcomes this machine can end with (its `final:` values, in order)."""
        out: list[str] = []
        for st in self.states.values():
            if st.final is not None and st.final not in out:
                out.append(st.final)
        return out

    def walk(self, prefix: str = ""):
        """Yield (dotted state path, state spec, node) for every state at every level."""
        for name, st in self.states.items():
            yield prefix + name, st, self
            child = self.children.get(name)
            if child is not None:
                yield from child.walk(prefix + name + ".")
            for bname, branch in self.branches.get(name, {}).items():
                if isinstance(branch, MachineNode):
                    yield from branch.walk(f"{prefix}{name}.{bname}.")

    def nodes(self):
        """This node and every nested machine node below it."""
        yield self
        for child in self.children.values():
            yield from child.nodes()
        for branches in self.branches.values():
            for branch in branches.values():
                if isinstance(branch, MachineNode):
                    yield from branch.nodes()

    def skill_branches(self):
        """Yield (state name, branch name, spec) of every single-skill branch of this level."""
        for name, branches in self.branches.items():
            for bname, branch in branches.items():
                if isinstance(branch, BranchSpec):
                    yield name, bname, branch


Branch = MachineNode | BranchSpec


def _declarations(raw: dict[str, Any]) -> tuple[dict[str, Any], dict[str, str]]:
    defaults: dict[str, Any] = {}
    types: dict[str, str] = {}
    for key, value in raw.items():
        if isinstance(value, BlackboardKey):
            defaults[key], types[key] = value.default, value.type
        else:
            defaults[key], types[key] = value, "any"
    return defaults, types


def load_machine_file(
    path: Path, allow: Sequence[Path] = (), limits: InputLimits | None = None
) -> tuple[MachineNode | None, list[Diagnostic]]:
    """Parse one machine file and its includes. Returns the tree (None if unusable) and every
    problem found; nothing is raised for user mistakes.

    Each included file is read once, however often it is included (a diamond of includes
    costs one read per file); machines nest at most `limits.max_machine_depth` deep and the
    whole tree, includes expanded, holds at most `limits.max_states` states.

    Args:
        path: The machine file.
        allow: Directories besides the including file's own tree that `machine:` may name.
        limits: Input limits (default: `current_limits()`).
    """
    loader = _Loader(tuple(allow), limits or current_limits())
    node, problems = loader.file(path, (), 0)
    if node is not None:
        total = _tree_size(node, {})
        if total > loader.limits.max_states:
            problems.append(
                node.source.diag(
                    ("states",),
                    f"the machine tree holds {total} states once its nested and included "
                    f"machines are expanded, more than {loader.limits.max_states} (limit "
                    "max_states; see docs/machine-language.md#limits)",
                )
            )
            return None, problems
    return node, problems


def _tree_size(node: MachineNode, memo: dict[int, int]) -> int:
    """States in the tree below `node`, every shared (included) machine counted each time."""
    if id(node) in memo:
        return memo[id(node)]
    total = len(node.states)
    for child in node.children.values():
        total += _tree_size(child, memo)
    for branches in node.branches.values():
        for branch in branches.values():
            if isinstance(branch, MachineNode):
                total += _tree_size(branch, memo)
    memo[id(node)] = total
    return total


def _height(node: MachineNode, memo: dict[int, int]) -> int:
    """Levels of machines nested below `node` (0: none)."""
    if id(node) not in memo:
        below = list(node.children.values())
        for branches in node.branches.values():
            below += [b for b in branches.values() if isinstance(b, MachineNode)]
        memo[id(node)] = max((1 + _height(c, memo) for c in below), default=0)
    return memo[id(node)]


class _Loader:
    """One machine tree being loaded: the include cache, the allowed directories, the limits."""

    def __init__(self, allow: tuple[Path, ...], limits: InputLimits) -> None:
        self.allow = allow
        self.limits = limits
        self.cache: dict[Path, MachineNode | None] = {}

    def file(
        self, path: Path, stack: tuple[Path, ...], depth: int
    ) -> tuple[MachineNode | None, list[Diagnostic]]:
        real = path.resolve()
        if real in self.cache:
            return self.cache[real], []  # already loaded (and its problems reported) once
        try:
            doc = load_yaml(path, self.limits)
        except ConfigError as exc:
            self.cache[real] = None
            return None, exc.diagnostics
        problems = list(doc.problems)
        if not isinstance(doc.data, dict):
            problems.append(
                doc.source.diag(
                    (), "a machine file must be a mapping with `name`, `initial` and `states`"
                )
            )
            self.cache[real] = None
            return None, problems
        try:
            spec = MachineSpec.model_validate(doc.data)
        except ValidationError as exc:
            reported = {d.path for d in problems}
            problems += [
                d
                for d in diagnostics_from_validation(exc, MachineSpec, doc.source, doc.data)
                if d.path not in reported
            ]
            self.cache[real] = None
            return None, problems
        defaults, types = _declarations(spec.blackboard)
        flags = {
            k: v.input
            for k, v in spec.blackboard.items()
            if isinstance(v, BlackboardKey) and v.input is not None
        }
        node = MachineNode(
            name=spec.name,
            initial=spec.initial,
            states=spec.states,
            blackboard=defaults,
            types=types,
            guards=list(spec.guards),
            on_abort=spec.on_abort,
            source=doc.source,
            events=dict(spec.events),
            inputs=flags,
            recovery=spec.recovery,
        )
        problems += self.children(node, path, (*stack, real), depth)
        self.cache[real] = node
        return node, problems

    def children(
        self, node: MachineNode, path: Path, stack: tuple[Path, ...], depth: int
    ) -> list[Diagnostic]:
        problems: list[Diagnostic] = []
        for name, st in node.states.items():
            at = (*node.at, "states", name)
            child, sub = self.nested(st, name, node.source, at, path, stack, depth)
            problems += sub
            if child is not None:
                node.children[name] = child
            for bname, branch in (st.parallel or {}).items():
                bat = (*at, "parallel", bname)
                if branch.skill is not None:
                    node.branches.setdefault(name, {})[bname] = branch
                    continue
                child, sub = self.nested(branch, bname, node.source, bat, path, stack, depth)
                problems += sub
                if child is not None:
                    node.branches.setdefault(name, {})[bname] = child
        return problems

    def nested(
        self,
        st: StateSpec | BranchSpec,
        name: str,
        source: SourceMap,
        at: tuple,
        path: Path,
        stack: tuple[Path, ...],
        depth: int,
    ) -> tuple[MachineNode | None, list[Diagnostic]]:
        """The nested machine of a state or branch (inline or included), if it has one."""
        if st.states is None and st.machine is None:
            return None, []
        if depth + 1 > self.limits.max_machine_depth:
            key = "states" if st.states is not None else "machine"
            return None, [
                source.diag(
                    (*at, key),
                    f"machines nest deeper than {self.limits.max_machine_depth} levels here "
                    "(limit max_machine_depth; see docs/machine-language.md#limits)",
                )
            ]
        if st.states is not None:
            child = MachineNode(
                name=name,
                initial=st.initial or "",
                states=st.states,
                blackboard={},
                guards=[],
                on_abort=None,
                source=source,
                at=at,
                top=False,
            )
            return child, self.children(child, path, stack, depth + 1)
        assert st.machine is not None
        found = resolve_include(st.machine, path, self.allow, self.limits)
        if found.path is None:
            return None, [source.diag((*at, "machine"), found.error or "", found.valid)]
        target = found.path
        if target.resolve() in stack:
            cycle = " -> ".join(p.name for p in (*stack, target.resolve()))
            return None, [source.diag((*at, "machine"), f"include cycle: {cycle}")]
        included, sub = self.file(target, stack, depth + 1)
        if included is not None:
            included.top = False
            if depth + 1 + _height(included, {}) > self.limits.max_machine_depth:
                # loaded before at a shallower place: its own nesting was checked from there
                return None, [
                    source.diag(
                        (*at, "machine"),
                        f"machines nest deeper than {self.limits.max_machine_depth} levels "
                        "through this include (limit max_machine_depth)",
                    )
                ]
        return included, sub


def initial_values(machine: MachineNode, overrides: dict[str, Any]) -> dict[str, Any]:
    """Blackboard values at the start of a run: the defaults declared in the machine tree
    (outer levels win), then `overrides` (the scenario's `blackboard:`)."""
    values: dict[str, Any] = {}

    def collect(node: MachineNode) -> None:
        for child in node.children.values():
            collect(child)
        values.update(node.blackboard)

    collect(machine)
    values.update(overrides)
    return values
