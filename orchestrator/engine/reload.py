"""Reloading a running machine's file between states (a live session's `reload`).

The new file is validated like any machine (the caller loads it). Then it must fit what is
running: at every active level the running state still exists, of the same kind (a skill, a
nested machine with the same levels below, a parallel state with the same branches), and the
states its outcomes lead to (and its retries: itself) exist in the new file. If it fits,
every level adopts its new definition as it enters its next state (`Executor.reloaded`): the
state running finishes as it was defined when it was entered (its skill's parameters, its
timeout, where its outcomes lead) and every state entered afterwards runs as the new file
says. The guards the new file declares are built at once and take effect with their levels.
"""

from __future__ import annotations

from ..language.loading import MachineNode
from ..language.machine import StateSpec
from .executor import Executor, node_at

__all__ = ["apply_reload", "reload_problems"]


def _kind(node: MachineNode, name: str) -> str:
    spec: StateSpec = node.states[name]
    if spec.final is not None:
        return "a final state"
    if spec.skill is not None:
        return f"skill {spec.skill!r}"
    if name in node.branches:
        return f"a parallel state of branches {sorted(node.branches[name])}"
    return "a nested machine"


def reload_problems(ex: Executor, root: MachineNode) -> list[str]:
    """Why `root` cannot replace the machine `ex` runs now (empty: it can)."""
    if ex.done or ex.region is None:
        return ["the task's machine has ended"]
    if root.name != ex.root.name:
        return [f"the running task runs machine {ex.root.name!r}, the file is {root.name!r}"]
    problems = []
    for region in ex.region.regions():
        if region.final is not None:
            continue
        level = region.prefix.rstrip(".") or "the top level"
        new = node_at(root, region.prefix)
        state = region.state
        if new is None:
            problems.append(f"{level}: runs now and is not in the new file")
            continue
        if state not in new.states:
            valid = ", ".join(new.states)
            problems.append(f"{region.prefix}{state}: runs now and is not in the new file "
                            f"(its states: {valid})")  # fmt: skip
            continue
        old_kind, new_kind = _kind(region.node, state), _kind(new, state)
        if old_kind != new_kind:
            problems.append(f"{region.prefix}{state}: runs now as {old_kind}, the new file "
                            f"makes it {new_kind}")  # fmt: skip
        for outcome, target in region.spec.transitions.items():
            if target not in new.states:
                problems.append(f"{region.prefix}{state}: its outcome {outcome!r} leads to "
                                f"{target}, which is not in the new file")  # fmt: skip
    return problems


def apply_reload(ex: Executor, root: MachineNode) -> None:
    """Let every level of `ex` adopt `root` at its next state entry (after
    `reload_problems` found none); the guards `root` declares are built now."""
    for node in root.nodes():
        ex._build_guards(node)  # the executor's own table of guards, by level
    ex.reloaded = root
