"""Exit codes and the one way each kind of refusal is said (a clean line on stderr, no
traceback)."""

import typer

from ..exceptions import ConfigError
from .console import err

EXIT_INVALID = 2
EXIT_BREAK = 6
"""`run --break ...` stopped at a break point and wrote its snapshot."""
EXIT_ERROR = 4
"""Outcome `error`: a skill raised, or the run went past `--max-wall-s` (README's table)."""
EXIT_PIPE = 141
"""Whoever read stdout closed it (`| head -c1`): what a shell reports for SIGPIPE (128 + 13)."""


def fail(message: str) -> None:
    """One clean line on stderr, exit 2."""
    err.print(f"error: {message}", markup=False, soft_wrap=True)
    raise typer.Exit(EXIT_INVALID)


def fail_config(exc: ConfigError, what: str = "nothing was simulated") -> None:
    """Every diagnostic of `exc` (file:line, key, value, fix), a count and `what` did not
    happen; exit 2."""
    from ..language.diagnostics import collapse

    diagnostics = collapse(exc.diagnostics)  # one mistake said once, with where else it is
    for diag in diagnostics:
        err.print(str(diag), markup=False, soft_wrap=True)
    n = len(diagnostics)
    what = "the run was stopped" if exc.during_run else what
    err.print(f"{n} error{'s' if n != 1 else ''}; {what}.", style="red")
    raise typer.Exit(EXIT_INVALID)


def live_error(exc: Exception, code: int = EXIT_INVALID) -> None:
    """A live command refused or failed: one line, exit `code` (2, or 5: the session lost)."""
    err.print(f"error: {exc}", markup=False, soft_wrap=True)
    raise typer.Exit(code)
