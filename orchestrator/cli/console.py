"""Where the command line writes: the two lazy rich consoles, plain lines, strict JSON."""

import functools
import sys
from typing import TYPE_CHECKING, Any, cast

if TYPE_CHECKING:
    from rich.console import Console

# Whatever a user file holds can reach these consoles (state names, messages, paths): no
# emoji codes (`:100:` in `file:100:7` would print as an emoji), no highlighting, and every
# user string passes `markup=False` or `escape()`.
_WIDE = 1000
"""Console width when the output is not a terminal: a pipe or a file gets unwrapped lines."""


class _LazyConsole:
    """A rich `Console`, made when first used: `--version` and a clean `validate` print plain
    lines (`plain`) and do not import rich (its console and markup are ~8 % of `validate`'s
    instructions)."""

    def __init__(self, stderr: bool) -> None:
        self._stderr = stderr

    @functools.cached_property
    def _console(self) -> "Console":
        from rich.console import Console

        tty = (sys.stderr if self._stderr else sys.stdout).isatty()
        return Console(
            stderr=self._stderr, highlight=False, emoji=False, width=None if tty else _WIDE
        )

    def __getattr__(self, name: str) -> Any:
        return getattr(self._console, name)


err = cast("Console", _LazyConsole(stderr=True))
out = cast("Console", _LazyConsole(stderr=False))


def rich_console(console: "Console") -> "Console":
    """The rich `Console` behind `out` or `err`, for code that is handed it: rich's `Live` (a
    progress bar, `watch`) enters it as a context manager, which a stand-in cannot be."""
    lazy = cast(Any, console)
    return lazy._console if isinstance(lazy, _LazyConsole) else console


_CONTROL = {c: f"\\x{c:02x}" for c in (*range(0x20), 0x7F, *range(0x80, 0xA0)) if c != 0x09}
"""Control characters, written as escapes by `plain` (a file name cannot move the cursor)."""


def plain(line: str) -> None:
    """One line on stdout as it is, control characters escaped (no rich needed)."""
    sys.stdout.write(line.translate(_CONTROL) + "\n")


def escape(text: str) -> str:
    """`text` with rich's markup escaped (rich.markup.escape, imported when first needed)."""
    from rich.markup import escape as rich_escape

    return rich_escape(text)


def strict_json(value: object) -> str:
    """`value` as strict JSON: non-finite numbers as null (engine/strict_json.py)."""
    from ..engine.strict_json import dumps

    return dumps(value)


def json_line(value: object) -> None:
    """Print one strict JSON document on stdout (what every `--json` prints)."""
    sys.stdout.write(strict_json(value) + "\n")
