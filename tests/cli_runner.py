"""The CLI in this process, as the console script runs it: Typer's app turned into its click
command once per process (as `orchestrator` does at start), then invoked with click's runner.

`typer.testing.CliRunner.invoke(app, ...)` builds the click command from the app on every call
(~30 ms: every command's parameters read from their signatures); the suite invokes the CLI about
a thousand times."""

from __future__ import annotations

import functools
from collections.abc import Sequence
from typing import Any

from click.testing import CliRunner, Result


@functools.cache
def command() -> Any:
    """The `orchestrator` click command (built once per process)."""
    import typer.main

    from orchestrator.cli import app

    return typer.main.get_command(app)


def _runner() -> CliRunner:
    """Click's runner with stderr apart from stdout (always so from click 8.2; asked for
    before)."""
    try:
        return CliRunner(mix_stderr=False)  # type: ignore[call-arg]
    except TypeError:  # click >= 8.2: no such option, stderr is always its own
        return CliRunner()


def invoke(args: Sequence[str], **kwargs: Any) -> Result:
    """`orchestrator ARGS` in this process (click's `CliRunner.invoke` keywords)."""
    return _runner().invoke(command(), list(args), **kwargs)
