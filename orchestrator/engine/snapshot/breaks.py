"""Break points: where `orchestrator run --break ...` stops a run and writes a snapshot.

* `--break STATE` (repeatable): the entry of a state, named by its dotted path or any
  trailing part of it (`GRASP` matches `PICK.GRASP`; `GRASP.CLOSE` matches
  `PICK.GRASP.CLOSE`), nested machines, parallel states and their branches included;
  `STATE@N` is its N-th entry (a retry is an entry: `GRASP@2` is the first retry).
* `--break-on guard` (or a guard's name, or `estop`): the abort of a guard.
* `--break-at T`: the first control tick at or after simulated time T [s].

The snapshot is taken at the start of the control tick in which the break point happens: the
machine has not ticked yet, so the state is entered as the first thing the resumed run does
(with any `--set` value already on the blackboard). The tick is found by running the episode
once to the break point and again to the start of that tick (the run is deterministic).
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from dataclasses import dataclass

from ...exceptions import ConfigError
from ...guards import GUARDS
from ...language.diagnostics import Diagnostic, did_you_mean
from ...language.loading import MachineNode
from ...language.machine import ESTOP, SAFE_STOP

__all__ = ["ANY_GUARD", "BreakPoint", "break_points", "final_paths", "state_paths"]

ANY_GUARD = "guard"
"""`--break-on guard`: the abort of any guard."""


@dataclass(frozen=True)
class BreakPoint:
    """One break point.

    Attributes:
        option: The option as the user wrote it (`--break GRASP@2`), for messages.
        state: A state (path or trailing part) whose entry breaks, or None.
        nth: Which entry of `state` breaks (1: the first).
        guard: A guard's name, `guard` (any) or None.
        at_t: Simulated time [s], or None.
    """

    option: str
    state: str | None = None
    nth: int = 1
    guard: str | None = None
    at_t: float | None = None

    def matches(self, path: str) -> bool:
        """The entry of `path` is an entry of this break point's state."""
        return self.state is not None and (path == self.state or path.endswith("." + self.state))

    def label(self) -> str:
        """What it stops at, said for the user (`entry 2 of PICK.GRASP`)."""
        if self.state is not None:
            return self.state if self.nth == 1 else f"entry {self.nth} of {self.state}"
        if self.guard is not None:
            return "a guard's abort" if self.guard == ANY_GUARD else f"{self.guard}'s abort"
        return f"t={self.at_t:g} s"


def state_paths(node: MachineNode, prefix: str = "") -> Iterator[str]:
    """Every state's dotted path in a machine tree (what `Executor.entry_listeners` hears)."""
    for name in node.states:
        path = prefix + name
        yield path
        child = node.children.get(name)
        if child is not None:
            yield from state_paths(child, path + ".")
        for bname, branch in node.branches.get(name, {}).items():
            if isinstance(branch, MachineNode):
                yield from state_paths(branch, f"{path}.{bname}.")
            else:
                yield f"{path}.{bname}"


def final_paths(node: MachineNode, prefix: str = "") -> set[str]:
    """The dotted paths of the final states of a machine tree."""
    out = set()
    for name, spec in node.states.items():
        path = prefix + name
        if spec.final is not None:
            out.add(path)
        child = node.children.get(name)
        if child is not None:
            out |= final_paths(child, path + ".")
        for bname, branch in node.branches.get(name, {}).items():
            if isinstance(branch, MachineNode):
                out |= final_paths(branch, f"{path}.{bname}.")
    return out


def break_points(
    machine: MachineNode,
    states: Iterable[str] = (),
    guards: Iterable[str] = (),
    at_t: float | None = None,
) -> list[BreakPoint]:
    """The break points of `--break`, `--break-on` and `--break-at`, checked against
    `machine`.

    Raises:
        ConfigError: A state no path of the machine ends with, an unknown guard, an N < 1, a
            time that is not a finite number >= 0 (every problem, each located at its option).
    """
    paths = [*state_paths(machine), SAFE_STOP]
    points: list[BreakPoint] = []
    problems: list[Diagnostic] = []
    for text in states:
        option = f"--break {text}"
        name, _, nth_text = text.partition("@")
        name = name.strip()
        nth = 1
        if nth_text:
            if not nth_text.strip().isdigit() or int(nth_text) < 1:
                problems.append(_diag("--break", text, "N of STATE@N must be a whole number >= 1"))
                continue
            nth = int(nth_text)
        point = BreakPoint(option, state=name, nth=nth)
        if not name or not any(point.matches(p) for p in paths):
            problems.append(
                _diag(
                    "--break",
                    text,
                    f"no state {name!r} in machine {machine.name!r}"
                    + did_you_mean(name, [*paths, *{p.rsplit(".", 1)[-1] for p in paths}]),
                    paths,
                )
            )
            continue
        points.append(point)
    valid_guards = (ANY_GUARD, ESTOP, *sorted(GUARDS))
    for text in guards:
        if text not in valid_guards:
            hint = did_you_mean(text, valid_guards)
            problems.append(_diag("--break-on", text, "not a guard" + hint, valid_guards))
            continue
        points.append(BreakPoint(f"--break-on {text}", guard=text))
    if at_t is not None:
        if not at_t >= 0.0 or at_t == float("inf"):
            problems.append(_diag("--break-at", str(at_t), "give a finite time >= 0 [s]"))
        else:
            points.append(BreakPoint(f"--break-at {at_t:g}", at_t=float(at_t)))
    if problems:
        raise ConfigError(problems)
    return points


def _diag(option: str, text: str, message: str, valid: Iterable[str] = ()) -> Diagnostic:
    return Diagnostic(f"<{option}>", 0, 0, text, message, tuple(valid))
