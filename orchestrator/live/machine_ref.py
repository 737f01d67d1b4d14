"""Which machine a live command may name, answered without telling what exists on the server.

A client names a task's machine (`run`, `reload`) as a bundled name or a file. The loader's
own messages say whether a file is outside the allowed folders or missing; over the wire that
would let a client probe the server's file system ("is outside" means it exists). A live
command gets one message for both: `refusal` is checked before anything is loaded.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from ..language.bundled import bundled_names
from ..language.includes import resolve_include
from ..language.limits import current_limits
from .wire import quote

__all__ = ["refusal"]


def refusal(ref: str, scenario: Path, allow: Sequence[Path | str]) -> str | None:
    """Why `ref` cannot be a live task's machine (None: it is bundled, or a file under the
    scenario's folder or an `--allow-path` folder). The same words whether the file is
    missing or outside those folders."""
    found = resolve_include(ref, scenario, [Path(a) for a in allow], current_limits(), "machine")
    if found.path is not None:
        return None
    return (
        f"machine {quote(ref)}: not a machine this session can load: give a bundled name "
        f"({', '.join(bundled_names('machines'))}) or a file under the scenario's folder or a "
        "folder the session was started with (serve --allow-path DIR)"
    )
