"""The `orchestrator` Typer app itself: its root options (--version), the time the command
began, and `main`, the console-script entry point (a closed stdout exits 141, no traceback).
Its commands are registered in cli/__init__.py."""

# No `from __future__ import annotations`: typer reads the parameter annotations of every
# command each time the CLI starts; as strings, each would be compiled and evaluated again
# (cli/__init__.py).
import os
import sys
import time
from typing import Annotated

import typer

from .console import plain
from .errors import EXIT_PIPE

app = typer.Typer(
    name="orchestrator",
    help="Run declarative YAML robot task flows on MuJoCo physics.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)


def _version(value: bool) -> None:
    if value:
        from importlib.metadata import version

        from ..world.native import native

        # which path runs the per-step arithmetic: the compiled extension or its Python twin
        step = "compiled" if native() is not None else "pure Python"
        plain(f"orchestrator {version('embodied-orchestrator')} (physics step: {step})")
        raise typer.Exit()


@app.callback()
def _root(
    version: Annotated[
        bool,
        typer.Option("--version", callback=_version, is_eager=True, help="Print the version."),
    ] = False,
) -> None:
    """Run declarative YAML robot task flows on MuJoCo physics."""
    global _STARTED  # noqa: PLW0603 - when this invocation began (the printed command time)
    _STARTED = time.perf_counter()


_STARTED = time.perf_counter()
"""When the command began (reset by every invocation): a run prints its episode's wall time
beside the command's, which also loads the framework, the scenario or the snapshot."""


def command_started() -> float:
    """`time.perf_counter()` when this invocation began."""
    return _STARTED


def main() -> None:
    """Console-script entry point. A closed stdout (`orchestrator run x --json | head -c1`)
    exits `EXIT_PIPE` without a traceback, whatever the command was doing."""
    was_null = _is_devnull(1)
    try:
        app()
    except SystemExit:
        if _stdout_closed(was_null):
            raise SystemExit(EXIT_PIPE) from None
        raise


def _is_devnull(fd: int) -> bool:
    try:
        st, null = os.fstat(fd), os.stat(os.devnull)
    except OSError:
        return False
    return (st.st_dev, st.st_ino) == (null.st_dev, null.st_ino)


def _stdout_closed(was_null: bool) -> bool:
    """Did writing stdout meet a closed pipe? rich points stdout at /dev/null and exits 1 when
    its write raised EPIPE, click (or typer's copy of it) wraps `sys.stdout` in its
    `PacifyFlushWrapper`; the last flush may meet it too."""
    wrapped = type(sys.stdout).__name__ == "PacifyFlushWrapper"
    if wrapped or (not was_null and _is_devnull(1)):
        return True
    try:
        sys.stdout.flush()
    except BrokenPipeError:
        # nothing more reaches the reader: the interpreter's own flush at exit must not fail
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return True
    except (OSError, ValueError):
        return False
    return False
