"""A scenario's `skills:` folders: kept inside the file's own tree, imported only to run.

A skill folder is Python: importing it runs its code. So

* an entry resolves relative to the scenario file and must stay inside that file's directory
  tree once symlinks are followed (or inside an `--allow-path` directory), every module of
  the folder included: an absolute path, a `../..` escape or an in-tree symlink that points
  out is refused before anything is read, as a `machine:` include is (`includes.py`) —
  unless the user imported that very folder with `--skills`;
* only commands that run the scenario (`run`, `batch`, `faults`, `serve`) import it. The
  commands that read a file (`validate`, `graph`, `show`) import nothing a file names: the
  machine is checked against the skills they know — the bundled ones, installed plugins and
  the folders the user passed with `--skills` — and a skill only the scenario's own folder
  could define is reported as unknown, with the fix (`pass --skills DIR`).
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Sequence
from pathlib import Path

from ..skills import SkillLoadError
from ..skills.plugins import SkillOutsideError, is_loaded, skill_files
from ..success import register_plugin_path
from .diagnostics import Diagnostic, clip
from .limits import InputLimits
from .yamlio import SourceMap

__all__ = ["hint_unimported", "register_scenario_skills", "register_user_skills"]

_USER_REGISTERED: set[str] = set()
"""`--skills` paths this process registered (`register_user_skills`)."""


def register_user_skills(paths: Sequence[str]) -> None:
    """Register `--skills` folders or files, each once per process (a batch worker does it
    before loading the scenario: one forked before the CLI registered them, or a Ray
    worker, has not).

    Raises:
        SkillLoadError: A path cannot be loaded or defines neither skills nor checks.
    """
    for path in paths:
        if path not in _USER_REGISTERED:
            register_plugin_path(path)
            _USER_REGISTERED.add(path)


def register_scenario_skills(
    entries: object,
    scenario_file: Path,
    allow: Sequence[Path],
    source: SourceMap,
    limits: InputLimits,
    import_skills: bool,
) -> tuple[list[Diagnostic], list[str]]:
    """Check (and, when `import_skills`, register) the scenario's `skills:` entries.

    Args:
        entries: The raw `skills:` value (anything but a list is left to the model's check).
        scenario_file: The scenario file; entries are relative to its directory.
        allow: Directories besides that tree the entries may lie in (`--allow-path`).
        source: Where the entries are written (for messages).
        limits: `max_ref_chars` bounds an entry's length.
        import_skills: Import the modules (a command that runs the scenario). Otherwise an
            entry is only resolved and checked; its skills are known when the user imported
            the same folder already (`--skills`).

    Returns:
        The problems, and the entries left unimported (as the user would pass them with
        `--skills`, relative to the working directory).
    """
    if not isinstance(entries, list):
        return [], []
    roots = (scenario_file.parent, *allow)
    problems: list[Diagnostic] = []
    unimported: list[str] = []
    for i, entry in enumerate(entries):
        if not isinstance(entry, str):
            continue  # the model reports the type
        if len(entry) > limits.max_ref_chars or "\x00" in entry or not entry.strip():
            why = f"{clip(entry)!r} is not a skill folder or file name"
            problems.append(source.diag(("skills", i), why))
            continue
        where = scenario_file.parent / entry
        try:
            try:
                files, within = skill_files(where, roots), roots  # confined; imports nothing
            except SkillOutsideError as outside:
                files, within = _imported_by_user(where, outside), None
            if import_skills or is_loaded(files):
                register_plugin_path(where, within)  # its skills and success checks
            else:
                unimported.append(_as_typed(where))
        except SkillLoadError as exc:
            problems.append(source.diag(("skills", i), str(exc)))
    return problems, unimported


def _imported_by_user(where: Path, outside: SkillOutsideError) -> list[Path]:
    """The modules of a folder outside the scenario's tree that the user imported already
    (`--skills` names the same folder: their choice, not the file's).

    Raises:
        SkillOutsideError: `outside`, when the user did not.
    """
    try:
        files = skill_files(where)
    except SkillLoadError:
        files = []
    if not files or not is_loaded(files):
        raise outside
    return files


def hint_unimported(diag: Diagnostic, unimported: Sequence[str]) -> Diagnostic:
    """An unknown skill or success check in a scenario whose `skills:` were not imported,
    with the fix."""
    if not unimported or not diag.message.startswith(("unknown skill", "unknown success check")):
        return diag
    fix = " ".join(f"--skills {u}" for u in unimported)
    message = (
        f"{diag.message}; the scenario's skills: are not imported here (no code a file names "
        f"runs): if it is there, pass {fix}"
    )
    return dataclasses.replace(diag, message=message)


def _as_typed(path: Path) -> str:
    """`path` as a user would type it here: relative to the working directory if below it."""
    try:
        rel = os.path.relpath(path)
    except ValueError:  # another drive (Windows)
        return str(path)
    return rel if not rel.startswith("..") else str(path)
