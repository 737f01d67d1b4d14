"""The `orchestrator` command line (the acceptance checks call exactly this).

One module per group of commands, the shared parts beside them:

* `root.py`: the Typer `app`, its root option (`--version`) and `main`, the console-script
  entry point (`orchestrator = "orchestrator.cli:main"` in pyproject.toml);
* `run.py`: `run`; `timetravel.py`: its break points and `--from`, and the `snapshot` group;
  `results.py`: a finished run said on the terminal;
* `inspect.py`: `validate`, `graph`, `schema`, `list`, `show`;
* `batch.py`: `batch`, `faults`;
* `live.py`: `serve`, `send`, `watch`, `ask`;
* `options.py`: option declarations shared by several commands and the checks of their
  values; `errors.py`: exit codes and how a refusal is said; `console.py`: where output goes.

To add a command: write its function in the module of its group (or a new module of this
package), typed with `Annotated[..., typer.Option(...)]` (shared options from `options.py`),
refusing bad input with `errors.fail` / `errors.fail_config` (exit 2, one clean line), and
register it below with one line: the order of `COMMANDS` is the order of `orchestrator --help`.
A new kind for `show` or `list` (`show robot`) is not a command: add it to `SHOWS` or `LISTS`
and its branch in inspect.py. A new group of subcommands is a `typer.Typer` added below with
`app.add_typer` (as `snapshot` is). A command imports what it needs inside its function:
`--version` and the reading commands must not load physics (tests/test_startup.py).

No module of this package has `from __future__ import annotations`: typer reads the parameter
annotations of every command each time the CLI starts (even for `--version`); as strings, each
would be compiled and evaluated: 15 % of `--version`'s instructions, 5 % of `validate`'s.
"""

from . import batch, inspect, live, run, timetravel
from .explore import explore_command
from .root import app, main

__all__ = ["app", "main"]

COMMANDS = (
    (run.run, None),
    (batch.faults, None),
    (inspect.validate, None),
    (inspect.graph, None),
    (inspect.schema, None),
    (inspect.list_, "list"),
    (inspect.show, None),
    (batch.batch, None),
    (explore_command, "explore"),
    (live.serve, None),
    (live.send, None),
    (live.watch, None),
    (live.ask, None),
)
"""Every command, in the order `orchestrator --help` lists them, with its name when it is not
the function's."""

for _command, _name in COMMANDS:
    app.command(name=_name)(_command)
app.add_typer(timetravel.snapshot_app, name="snapshot")
