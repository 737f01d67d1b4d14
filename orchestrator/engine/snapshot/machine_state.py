"""The machine's active path, as data, and how it is entered again without its entry actions.

Recorded: for each running machine level its state, and what that state runs — a skill (its
validated parameters and its `snapshot_state()`), a parallel group (each branch), a nested
level; the controlled stops under way; the faults and events still to come (by their index
in the scenario). Rebuilt on a run built the normal way: each level's `transitions` machine
is made in the recorded state, each activity is made without `start` (no entry action runs
twice: no listener, no log line, no setpoint), each skill is made from its recorded
parameters (validated by its own `Params`) and given its recorded state by its own
`restore_state(data)`. The rest of each object's state (a level's entry time and retries, a
branch's outcome, the executor's log of transitions) is plain data restored by path
(graph.py).
"""

from __future__ import annotations

from typing import Any

from ...guards.base import Violation
from ...language.loading import MachineNode
from ...skills import Skill, get_skill
from ...skills.plain_state import attributes
from ..executor import Executor
from ..regions import ParallelActivity as _ParallelActivity
from ..regions import Region as _Region
from ..regions import SkillActivity as _SkillActivity
from ..regions import _Model
from ..safety_stop import SafetyStop
from .errors import SnapshotError

__all__ = ["IncompleteState", "capture_machine", "restore_machine", "restore_skill_state"]


class IncompleteState(SnapshotError):
    """A running skill's declared state does not give back everything it held: the run
    resumes by replay instead (run_snapshot.load_run)."""


def _activity(a: Any) -> dict[str, Any] | None:
    if a is None:
        return None
    if isinstance(a, _Region):
        return {"kind": "region", **_region(a)}
    if isinstance(a, _ParallelActivity):
        return {"kind": "parallel", "branches": {b: _activity(x) for b, x in a.branches.items()}}
    assert isinstance(a, _SkillActivity)
    skill = a.skill
    if skill is None:
        return {"kind": "skill", "params": None, "state": None}
    return {
        "kind": "skill",
        "params": skill.params.model_dump(mode="python", by_alias=True),
        "state": skill.snapshot_state(),
        "attributes": sorted(attributes(skill)),
    }


def _region(r: _Region) -> dict[str, Any]:
    return {"state": r.model.state, "activity": _activity(r.activity)}


def capture_machine(run: Any) -> dict[str, Any]:
    """The executor's active path, its stops and the injector's queue (module docstring)."""
    ex, episode, injector = run.executor, run.episode, run.injector
    end = episode.end_stop
    queue = []
    for t, seq, action in injector._queue:
        func = getattr(action, "func", None)
        name = getattr(func, "__name__", "")
        args = list(getattr(action, "args", ()))
        if name == "_start":
            queue.append([t, seq, "fault", args[0]])
        elif name == "event":
            queue.append([t, seq, "event", *args])
        else:
            raise ValueError(f"an injector action of no known kind ({name or action!r})")
    return {
        "region": _region(ex.region) if ex.region is not None else None,
        "stop": ex.stop is not None,
        "end_stop": None if end is None else ("executor" if end is ex.stop else "own"),
        "queue": queue,
        "on_enter": {p: [i for i, _ in v] for p, v in injector._on_enter.items()},
    }


def restore_skill_state(cls: type[Skill], rec: dict[str, Any], where: str) -> Skill | None:
    """A running skill made again: its recorded parameters validated by its `Params`, its
    state given by its `restore_state`."""
    if rec.get("params") is None:
        return None
    skill = cls(cls.Params.model_validate(rec["params"]))
    state = rec.get("state")
    if not isinstance(state, dict):
        raise ValueError(f"{where}: the skill's state is not a mapping")
    skill.restore_state(state)
    had = rec.get("attributes")
    if isinstance(had, list):
        missing = sorted(set(map(str, had)) - set(attributes(skill)))
        if missing:
            raise IncompleteState(
                f"skill {cls.name!r} at {where} holds {', '.join(missing[:4])} beyond its "
                "snapshot_state (declare them in its snapshot_state and restore_state)"
            )
    return skill


def _skill_activity(ex: Executor, node: MachineNode, at: tuple, path: str, spec: Any,
                    timeout: float | None, rec: dict[str, Any]) -> _SkillActivity:  # fmt: skip
    if rec.get("kind") != "skill" or spec.skill is None:
        raise ValueError(f"{path}: the snapshot's activity is not this state's skill")
    a = _SkillActivity.__new__(_SkillActivity)
    a.ex, a.node, a.at, a.path = ex, node, at, path
    a.failed = False
    a.cls = get_skill(spec.skill)
    a.timeout = timeout
    a.t0 = ex.ctx.clock
    a.skill = restore_skill_state(a.cls, rec, path)
    return a


def _rebuild_region(ex: Executor, node: MachineNode, prefix: str, rec: Any) -> _Region:
    if not isinstance(rec, dict) or rec.get("state") not in node.states:
        raise ValueError(f"{prefix or 'the top level'}: no such state in the machine")
    r = _Region(ex, node, prefix)
    state = rec["state"]
    if state != r.model.state:
        r.model = _Model()
        r.fsm = r._machine(node, state)
    r.activity = _rebuild_activity(ex, r, state, rec.get("activity"))
    return r


def _rebuild_activity(ex: Executor, region: _Region, name: str, rec: Any) -> Any:
    if rec is None:
        return None
    node, st, path = region.node, region.node.states[name], region.prefix + name
    at = (*node.at, "states", name)
    kind = rec.get("kind") if isinstance(rec, dict) else None
    if kind == "skill":
        return _skill_activity(ex, node, at, path, st, None, rec)
    if kind == "region":
        if name not in node.children:
            raise ValueError(f"{path}: not a nested machine")
        return _rebuild_region(ex, node.children[name], path + ".", rec)
    if kind != "parallel" or name not in node.branches:
        raise ValueError(f"{path}: the snapshot's activity does not fit this state")
    g = _ParallelActivity.__new__(_ParallelActivity)
    g.ex, g.path, g.rule = ex, path, st.rule
    g.branches, g.success, g.done = {}, {}, {}
    recorded = rec.get("branches")
    if not isinstance(recorded, dict) or set(recorded) != set(node.branches[name]):
        raise ValueError(f"{path}: the snapshot's branches are not this state's")
    for bname, branch in node.branches[name].items():
        bpath = f"{path}.{bname}"
        if isinstance(branch, MachineNode):
            g.branches[bname] = _rebuild_region(ex, branch, bpath + ".", recorded[bname])
        else:
            bat = (*at, "parallel", bname)
            g.branches[bname] = _skill_activity(
                ex, node, bat, bpath, branch, branch.timeout, recorded[bname]
            )
    return g


def restore_machine(run: Any, rec: dict[str, Any]) -> None:
    """Make the recorded active path, stops and queue on `run` (built the normal way, not
    started). The plain data of what it makes is put back by path afterwards."""
    ex, episode, injector = run.executor, run.episode, run.injector
    if rec["region"] is not None:
        ex.region = _rebuild_region(ex, ex.root, "", rec["region"])
    safe_stop = run.loaded.scenario.physics.safe_stop
    ex.stop = ex.new_stop() if rec["stop"] else None
    end = rec["end_stop"]
    episode.end_stop = (
        ex.stop if end == "executor" else SafetyStop(run.ctx, safe_stop) if end == "own" else None
    )
    faults = list(run.loaded.scenario.faults)
    queue = []
    for item in rec["queue"]:
        t, seq, kind, *args = item
        if kind == "fault" and isinstance(args[0], int) and 0 <= args[0] < len(faults):
            queue.append((t, seq, injector._starter(args[0], faults[args[0]])))
        elif kind == "event" and len(args) == 2:
            queue.append((t, seq, injector._sender(str(args[0]), str(args[1]))))
        else:
            raise ValueError(f"an injector entry of no known kind: {str(item)[:80]}")
    injector._queue = queue  # in the recorded (heap) order
    injector._on_enter = {str(p): [(i, faults[i]) for i in v] for p, v in rec["on_enter"].items()}


def settle_machine(run: Any) -> None:
    """After the plain data is back: the abort's reason as the named tuple it is, and the
    guards the restored path has active (activated, then their own state put back by the
    caller)."""
    ex = run.executor
    if isinstance(ex.violation, tuple) and not isinstance(ex.violation, Violation):
        ex.violation = Violation(*ex.violation)
    ex.active_guards = []
    ex.changed()
    ex._bind_checks()
