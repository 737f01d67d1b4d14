"""Load machines (with their nested and included machines) into a tree the executor runs."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from pydantic import ValidationError

from .bundled import bundled_names, resolve_file
from .diagnostics import Diagnostic
from .exceptions import ConfigError
from .machine import GuardRef, MachineSpec, StateSpec
from .pydantic_errors import diagnostics_from_validation
from .yamlio import SourceMap, load_yaml

__all__ = ["MachineNode", "load_machine", "load_machine_file"]


@dataclass
class MachineNode:
    """One machine level, ready to run: its states and, per state, what runs there.

    Attributes:
        name: Machine name (the file's `name:`, or the state name for inline machines).
        initial: The initial state.
        states: State name -> spec.
        blackboard: Declared keys and defaults of this level.
        guards: Machine-level guards.
        on_abort: State entered after a guard fires (None: the built-in safe stop).
        children: State name -> nested machine for `machine:` and inline `states:`.
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


def load_machine_file(path: Path, _stack: tuple[Path, ...] = ()) -> tuple[MachineNode | None, list[Diagnostic]]:
    """Parse one machine file and its includes. Returns the tree (None if unusable) and every
    problem found; nothing is raised for user mistakes."""
    try:
        doc = load_yaml(path)
    except ConfigError as exc:
        return None, exc.diagnostics
    problems = list(doc.problems)
    if not isinstance(doc.data, dict):
        problems.append(doc.source.diag((), "a machine file must be a mapping with `name`, "
                                        "`initial` and `states`"))
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
        return None, problems
    node = MachineNode(
        name=spec.name,
        initial=spec.initial,
        states=spec.states,
        blackboard=dict(spec.blackboard),
        guards=list(spec.guards),
        on_abort=spec.on_abort,
        source=doc.source,
    )
    problems += _load_children(node, path, (*_stack, path.resolve()))
    return node, problems


def _load_children(node: MachineNode, path: Path, stack: tuple[Path, ...]) -> list[Diagnostic]:
    problems: list[Diagnostic] = []
    for name, st in node.states.items():
        at = (*node.at, "states", name)
        if st.states is not None:
            child = MachineNode(
                name=name,
                initial=st.initial or "",
                states=st.states,
                blackboard={},
                guards=[],
                on_abort=None,
                source=node.source,
                at=at,
            )
            problems += _load_children(child, path, stack)
            node.children[name] = child
        elif st.machine is not None:
            target = resolve_file(st.machine, "machines", path.parent)
            if target is None:
                problems.append(
                    node.source.diag(
                        (*at, "machine"),
                        f"machine file {st.machine!r} not found (relative to {path.parent}, "
                        "nor a bundled machine)",
                        tuple(bundled_names("machines")),
                    )
                )
                continue
            if target.resolve() in stack:
                cycle = " -> ".join(p.name for p in (*stack, target.resolve()))
                problems.append(
                    node.source.diag((*at, "machine"), f"include cycle: {cycle}")
                )
                continue
            child, sub = load_machine_file(target, stack)
            problems += sub
            if child is not None:
                node.children[name] = child
    return problems


def load_machine(ref: str, base_dir: Path | None = None) -> MachineNode:
    """Load and statically validate a machine by path or bundled name.

    Raises:
        ConfigError: With every problem found, each located in its file.
    """
    from .validation import validate_machine

    path = resolve_file(ref, "machines", base_dir)
    if path is None:
        raise ConfigError(
            [
                Diagnostic(
                    ref, 0, 0, "<machine>",
                    "no such machine file or bundled machine",
                    tuple(bundled_names("machines")),
                )
            ]
        )
    node, problems = load_machine_file(path)
    if node is not None:
        problems += validate_machine(node)
    if problems:
        raise ConfigError(problems)
    assert node is not None
    return node
