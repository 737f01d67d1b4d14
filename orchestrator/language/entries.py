"""What a SCENARIO (or MACHINE) argument names: one rule for `run`, `batch`, `faults`,
`serve`, `graph`, `show` and `validate`.

1. A path to an existing file is that file, a machine or a scenario by its keys (`states:`
   makes a machine); a machine runs in the default scene (`default_scene.py`).
2. Otherwise a bundled scenario of that name (with or without `.yaml`).
3. Otherwise a bundled machine of that name, in the default scene.
4. Otherwise nothing: the message lists the bundled names with the closest one.

Every bundled scenario runs the bundled machine of its own name (or another one), so a name
that is both means the same flow either way. A bare name that is also a file in the working
directory (`pick_place` beside a file `pick_place`, or `pick_place.yaml` there) gets a note
saying which one is used.
"""

from __future__ import annotations

import difflib
import re
from pathlib import Path

from ..exceptions import ConfigError
from .bundled import bundled_names, bundled_path, is_file
from .diagnostics import Diagnostic
from .limits import current_limits
from .yamlio import load_yaml

__all__ = ["entry_file", "entry_note", "file_kind", "unknown_entry"]


_TOP_KEY = re.compile(r"^([A-Za-z_][A-Za-z0-9_-]*)[ \t]*:", re.MULTILINE)
"""A key at the start of a line: the top-level keys of a block-style file."""


def _kind_of(keys: set[str] | None, path: Path) -> str:
    """Machine or scenario, from the file's top-level keys (None: it does not parse)."""
    if keys is None:
        return "machine" if "machine" in path.parts else "scenario"
    if "states" in keys:
        return "machine"
    if keys & {"scene", "robot", "machine"}:
        return "scenario"
    return "machine" if "initial" in keys else "scenario"


def _top_keys(path: Path) -> set[str] | None:
    """The top-level keys of `path`: read off the lines of a block-style file (no second full
    parse of a large file), else from its parsed YAML; None if it does not parse."""
    try:
        with path.open("rb") as f:
            head = f.read(current_limits().max_file_bytes + 1)
        keys = set(_TOP_KEY.findall(head.decode("utf-8", errors="replace")))
    except OSError:
        keys = set()
    if keys & {"states", "initial", "scene", "robot", "machine"}:
        return keys
    try:
        data = load_yaml(path).data
    except ConfigError:
        return None
    if not isinstance(data, dict):
        return set()
    return {k for k, v in data.items() if k != "machine" or isinstance(v, str)}


def file_kind(ref: str) -> tuple[str, str] | None:
    """(`machine` or `scenario`, the file or bundled name) `ref` names by the rule of this
    module; None if it names nothing."""
    path = Path(ref)
    if is_file(path):
        return _kind_of(_top_keys(path), path), str(path)
    if bundled_path("scenarios", ref) is not None:
        return "scenario", ref
    if bundled_path("machines", ref) is not None:
        return "machine", ref
    return None


def entry_file(ref: str) -> Path | None:
    """The file `ref` names by the rule (a file, a bundled scenario, a bundled machine)."""
    path = Path(ref)
    if is_file(path):
        return path
    return bundled_path("scenarios", ref) or bundled_path("machines", ref)


def entry_note(ref: str) -> str | None:
    """What to tell the user when `ref` could have meant two things, else None."""
    kind = file_kind(ref)
    if kind is None:
        return None
    bundled = [k[:-1] for k in ("scenarios", "machines") if bundled_path(k, ref) is not None]
    if is_file(Path(ref)) and bundled and "/" not in ref:
        return (
            f"{ref} is the file ./{ref} here, not the bundled {bundled[0]} of that name "
            "(run it from another folder to get the bundled one)"
        )
    local = Path(f"{ref}.yaml")
    if not is_file(Path(ref)) and "/" not in ref and is_file(local):
        return (
            f"{ref} is the bundled {kind[0]}; the file ./{local} here is not used (pass "
            f"./{local}, with its path, to use it)"
        )
    return None


def unknown_entry(ref: str, option: str = "<scenario>") -> Diagnostic:
    """The message for a reference that names nothing, with the closest names."""
    names = sorted({*bundled_names("scenarios"), *bundled_names("machines")})
    close = difflib.get_close_matches(ref, names, n=1, cutoff=0.6)
    hint = f" (did you mean {close[0]!r}?)" if close else ""
    return Diagnostic(
        ref,
        0,
        0,
        option,
        f"no such scenario or machine: not a file, a bundled scenario or a bundled machine{hint}",
        tuple(names),
    )
