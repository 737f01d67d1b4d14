"""A skill that raised: which one, in which of its methods, where in its file, and why.

A bug in a skill's own code (an exception out of `start`, `step`, `stop` or `explain`) ends
the run with outcome `error` (exit code 4): the arm is brought to rest by the controlled stop
and held, and the result says the skill, its file:line and the exception in one line; the
traceback is kept in the result (`error.traceback`) and printed by `run --debug`.
"""

from __future__ import annotations

import builtins
import inspect
import os
import traceback
from dataclasses import asdict, dataclass
from typing import Any

__all__ = ["SkillFault"]


@dataclass(frozen=True)
class SkillFault:
    """What a raising skill did.

    Attributes:
        skill: The skill's YAML name.
        method: The method that raised (`start`, `step`, `stop`, `explain`, `__init__`).
        state: Dotted path of the state that ran it.
        t: Simulated time of the exception [s].
        type: The exception's class name.
        message: The exception's text (its first line).
        where: `file:line` in the skill's own file where it raised (the innermost frame in
            that file; the class definition if no frame is in it).
        traceback: The formatted traceback.
    """

    skill: str
    method: str
    state: str
    t: float
    type: str
    message: str
    where: str
    traceback: str

    @classmethod
    def of(
        cls, skill_cls: builtins.type, method: str, state: str, t: float, exc: BaseException
    ) -> SkillFault:
        """The fault of `skill_cls`, whose `method` raised `exc` at simulated time `t` [s]."""
        text = str(exc).strip()
        return cls(
            skill=str(getattr(skill_cls, "name", skill_cls.__name__)),
            method=method,
            state=state,
            t=round(t, 6),
            type=builtins.type(exc).__name__,
            message=text.splitlines()[0] if text else "",
            where=_where(skill_cls, exc),
            traceback="".join(traceback.format_exception(exc)),
        )

    def line(self) -> str:
        """The one line a user reads: skill, file:line, exception, state and time."""
        what = f"{self.type}: {self.message}" if self.message else self.type
        return (
            f"skill {self.skill!r} raised {what} ({self.where}, in {self.method}; state "
            f"{self.state} at t={self.t:.3f} s)"
        )

    def to_dict(self) -> dict[str, Any]:
        """The result's `error` object (`type`, `message` and `traceback` as a batch's error
        lines have them, plus where and when)."""
        return asdict(self)


def _where(skill_cls: type, exc: BaseException) -> str:
    try:
        file = inspect.getsourcefile(skill_cls)
    except TypeError:
        file = None
    frames = traceback.extract_tb(exc.__traceback__)
    mine = [f for f in frames if file is not None and f.filename == file]
    if mine:
        return f"{_shown(mine[-1].filename)}:{mine[-1].lineno}"
    if file is not None:  # raised outside its file (e.g. by the framework on its behalf)
        try:
            line = inspect.getsourcelines(skill_cls)[1]
        except (OSError, TypeError):
            line = 0
        return f"{_shown(file)}:{line}"
    last = frames[-1] if frames else None
    return f"{_shown(last.filename)}:{last.lineno}" if last is not None else "<unknown>"


def _shown(path: str) -> str:
    """`path` relative to the working directory when it lies below it (as a user wrote it)."""
    try:
        rel = os.path.relpath(path)
    except ValueError:  # another drive
        return path
    return path if rel.startswith("..") else rel
