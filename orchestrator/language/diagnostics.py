"""Diagnostics: one user mistake, located in its file, with the fix."""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field

__all__ = ["Diagnostic", "format_path"]


def format_path(path: Iterable[str | int]) -> str:
    """`("states", "GRASP", "with", 0)` -> `states.GRASP.with[0]`."""
    out = ""
    for part in path:
        if isinstance(part, int):
            out += f"[{part}]"
        else:
            out += f".{part}" if out else str(part)
    return out or "<root>"


@dataclass(frozen=True)
class Diagnostic:
    """One problem in a user file.

    Attributes:
        file: The file it is in (or `<--set>` for a command-line override).
        line: 1-based line, 0 when unknown.
        col: 1-based column, 0 when unknown.
        path: Dotted path of the offending key, e.g. `states.GRASP.skill`.
        message: What is wrong and, where it helps, the fix.
        valid: The valid options, when there is a closed set of them.
    """

    file: str
    line: int
    col: int
    path: str
    message: str
    valid: tuple[str, ...] = field(default=())

    def __str__(self) -> str:
        where = f"{self.file}:{self.line}:{self.col}" if self.line else self.file
        text = f"{where}: {self.path}: {self.message}"
        if self.valid:
            text += f" (valid: {', '.join(self.valid)})"
        return text
