"""Diagnostics: one user mistake, located in its file, with the fix."""

from __future__ import annotations

import difflib
import re
from collections.abc import Iterable
from dataclasses import dataclass, field

__all__ = ["Diagnostic", "clip", "collapse", "did_you_mean", "format_path"]

MAX_QUOTED = 80
"""Longest quoted user value a message shows [characters]; longer ones are cut in the middle."""
MAX_VALID = 30
"""Most valid options a message lists."""
_QUOTED = re.compile(
    rf"(?<!\w)'[^'\n]{{{MAX_QUOTED},}}'(?!\w)|(?<!\w)\"[^\"\n]{{{MAX_QUOTED},}}\"(?!\w)"
)


def clip(text: str, limit: int = MAX_QUOTED) -> str:
    """`text` cut in the middle to about `limit` characters (`abc…xyz (5000 chars)`)."""
    if len(text) <= limit:
        return text
    half = (limit - 20) // 2
    return f"{text[:half]}…{text[-half:]} ({len(text)} chars)"


def _clip_quoted(message: str) -> str:
    """Every quoted value in `message` cut to about MAX_QUOTED characters."""
    if len(message) <= MAX_QUOTED:
        return message
    return _QUOTED.sub(lambda m: m.group()[0] + clip(m.group()[1:-1]) + m.group()[0], message)


def closest(name: object, names: Iterable[str], cutoff: float = 0.7) -> str | None:
    """The one of `names` closest to a misspelled `name` (difflib's ratio at least `cutoff`),
    else None: every "did you mean" of the project comes from here."""
    if not isinstance(name, str):
        return None
    close = difflib.get_close_matches(name, [str(n) for n in names], n=1, cutoff=cutoff)
    return close[0] if close and close[0] != name else None


def did_you_mean(name: object, names: Iterable[str], cutoff: float = 0.7) -> str:
    """` (did you mean 'X'?)` for the closest of `names` to a misspelled `name`, else ``."""
    close = closest(name, names, cutoff)
    return f" (did you mean {close!r}?)" if close is not None else ""


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

    def __post_init__(self) -> None:
        # Whatever a user file holds reaches the terminal only in short, quoted pieces.
        object.__setattr__(self, "file", clip(self.file, 200))
        object.__setattr__(self, "path", clip(self.path, 120))
        object.__setattr__(self, "message", clip(_clip_quoted(self.message), 600))
        valid = tuple(clip(str(v)) for v in self.valid[:MAX_VALID])
        if len(self.valid) > MAX_VALID:
            valid += (f"… {len(self.valid) - MAX_VALID} more",)
        object.__setattr__(self, "valid", valid)

    def __str__(self) -> str:
        where = f"{self.file}:{self.line}:{self.col}" if self.line else self.file
        text = f"{where}: {self.path}: {self.message}"
        if self.valid:
            text += f" (valid: {', '.join(self.valid)})"
        return text


_LISTED_LINES = 12
"""Most other lines a collapsed diagnostic names."""


def collapse(diagnostics: Iterable[Diagnostic]) -> list[Diagnostic]:
    """Repeated identical problems said once, with a count and the other lines they are on.

    Deleting a state that eleven transitions lead to is one mistake: it is reported at its
    first place, `... (11 places: also lines 15, 19, ...)`, not as eleven lines. Problems are
    identical when file, message and valid options are; the first keeps its place in the order.
    """
    groups: dict[tuple[str, str, tuple[str, ...]], list[Diagnostic]] = {}
    for d in diagnostics:
        groups.setdefault((d.file, d.message, d.valid), []).append(d)
    out = []
    for same in groups.values():
        first = same[0]
        if len(same) == 1:
            out.append(first)
            continue
        lines = sorted({d.line for d in same[1:] if d.line and d.line != first.line})
        also = ", ".join(str(n) for n in lines[:_LISTED_LINES])
        if len(lines) > _LISTED_LINES:
            also += ", ..."
        where = f": also line{'s' if len(lines) > 1 else ''} {also}" if lines else ""
        message = f"{first.message} ({len(same)} places{where})"
        out.append(Diagnostic(first.file, first.line, first.col, first.path, message, first.valid))
    return out
