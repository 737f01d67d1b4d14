"""Option declarations shared by several commands, and the checks of their values (a bad
value exits 2 before anything runs)."""

# No `from __future__ import annotations`: typer reads the parameter annotations of every
# command each time the CLI starts; as strings, each would be compiled and evaluated again
# (cli/__init__.py).
import math
import os
from pathlib import Path
from typing import Annotated, Literal

import typer

from .console import err
from .errors import EXIT_INVALID, fail

MAX_SEED = 2**63 - 1
"""Seeds are non-negative 64-bit integers (numpy's generators take any of them)."""

SeedOption = Annotated[
    int, typer.Option(min=0, max=MAX_SEED, help="Episode seed: randomization and noise (>= 0).")
]
AllowPathOption = Annotated[
    list[Path] | None,
    typer.Option(
        "--allow-path",
        help="A directory whose machine files (`machine:`) and skill folders (`skills:`) a "
        "file may name, besides the file's own directory tree (and the bundled machines). "
        "Repeatable.",
    ),
]
SkillPaths = Annotated[
    list[Path] | None,
    typer.Option(
        "--skills",
        help="A folder (or .py file) of your own skill modules (and success checks), no "
        "package needed: imported (its code runs), as you name it. Repeatable.",
    ),
]

# -- where a campaign's episodes run (batch, explore) -----------------------------------------

WorkersOption = Annotated[
    int | None, typer.Option(min=1, help="Worker processes / Ray CPUs (default: every core).")
]
BackendOption = Annotated[
    Literal["local", "ray"], typer.Option(help="Local worker processes, or Ray tasks.")
]
RayAddressOption = Annotated[
    str | None, typer.Option(help="Ray address (default: $RAY_ADDRESS, else a local Ray).")
]

# -- the options of a live session's clients (send, watch, ask; serve's --connect) --------

Endpoints = Annotated[
    list[str] | None,
    typer.Option("--connect", help="Zenoh endpoint of the session (default tcp/127.0.0.1:7447)."),
]
UserOption = Annotated[
    str | None,
    typer.Option("--user", envvar="ORCHESTRATOR_USER",
                 help="User name, for a session that authenticates (serve --users)."),
]  # fmt: skip
PasswordOption = Annotated[
    str | None,
    typer.Option("--password", envvar="ORCHESTRATOR_PASSWORD",
                 help="Its password (an option is visible in the process list: prefer the "
                 "environment variable or --credentials)."),
]  # fmt: skip
CredentialsOption = Annotated[
    Path | None,
    typer.Option("--credentials", envvar="ORCHESTRATOR_CREDENTIALS",
                 help="A file with one user:password line (readable by you only: chmod 600)."),
]  # fmt: skip
TlsCaOption = Annotated[
    Path | None,
    typer.Option("--tls-ca", envvar="ORCHESTRATOR_TLS_CA",
                 help="CA certificate (PEM) that signed the session's TLS certificate "
                 "(tls/ endpoints)."),
]  # fmt: skip
ClientCertOption = Annotated[
    Path | None,
    typer.Option("--tls-cert", envvar="ORCHESTRATOR_CLIENT_CERT",
                 help="This client's TLS certificate (PEM), signed by the CA the session "
                 "admits: a session beyond loopback asks for one (mutual TLS)."),
]  # fmt: skip
ClientKeyOption = Annotated[
    Path | None,
    typer.Option("--tls-key", envvar="ORCHESTRATOR_CLIENT_KEY",
                 help="Its private key (PEM, readable by you only: chmod 600)."),
]  # fmt: skip


def allowed_dirs(paths: list[Path] | None) -> tuple[Path, ...]:
    """The `--allow-path` directories, each checked to be one."""
    for path in paths or ():
        if not path.is_dir():
            what = "does not exist" if not path.exists() else "is not a directory"
            fail(f"--allow-path {path}: {what} (give a directory that holds machine files)")
    return tuple(paths or ())


def check_wall(max_wall_s: float | None) -> None:
    if max_wall_s is not None and not math.isfinite(max_wall_s):
        fail(f"--max-wall-s {max_wall_s}: give a finite number of seconds (omit it for no limit)")


def _is_dir(path: Path) -> bool:
    """`path.is_dir()`, False for names the system refuses (too long, a NUL byte)."""
    try:
        return path.is_dir()
    except (OSError, ValueError):
        return False


def check_writable(path: Path, option: str) -> None:
    """Refuse an output file that cannot be written, before anything runs. Its folder must
    exist: a mistyped path is said, never created (`/nonexistent/dir` is not made)."""
    if _is_dir(path):
        fail(f"{option} {path}: is a directory; give a file name, e.g. {path / 'run.rrd'}")
    parent = path.parent if str(path.parent) else Path(".")
    if not _is_dir(parent):
        if os.path.exists(parent):  # False, not an error, for a name the system refuses
            fail(f"{option} {path}: {parent} is not a folder; give a file in a folder")
        fail(f"{option} {path}: the folder {parent} does not exist: create it first, or give "
              "a file in a folder that exists")  # fmt: skip
    existed = path.exists()
    try:
        with path.open("ab"):
            pass
    except OSError as exc:
        fail(f"{option} {path}: cannot write it ({exc.strerror})")
    if not existed:
        path.unlink(missing_ok=True)


_warned = False


def use_skills(paths: list[Path] | None) -> None:
    """Register `--skills` folders (their skills and success checks), discover plugins and
    say which plugins were skipped."""
    global _warned  # noqa: PLW0603 - print plugin warnings once per process
    from ..skills import PLUGIN_WARNINGS, SkillLoadError, skill_names
    from ..success import check_kinds, register_plugin_path

    skill_names()
    check_kinds()
    if not _warned:
        for warning in PLUGIN_WARNINGS:
            err.print(f"warning: {warning}", markup=False, soft_wrap=True)
        _warned = True
    for path in paths or []:
        try:
            register_plugin_path(path)
        except SkillLoadError as exc:
            err.print(f"error: {exc}", markup=False, soft_wrap=True)
            raise typer.Exit(EXIT_INVALID) from None


def note_entry(ref: str) -> None:
    """Say which one a SCENARIO argument means when it could mean a file or a bundled name
    (the rule: language/entries.py)."""
    from ..language.entries import entry_note

    note = entry_note(ref)
    if note is not None:
        err.print(f"note: {note}", markup=False, soft_wrap=True)
