"""The `orchestrator` command line (the acceptance checks call exactly this)."""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console
from rich.table import Table

from .exceptions import ConfigError, OrchestratorError

__all__ = ["app", "main"]

app = typer.Typer(
    name="orchestrator",
    help="Run declarative YAML robot task flows on MuJoCo physics.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)
err = Console(stderr=True, highlight=False)
out = Console(highlight=False)

EXIT_INVALID = 2


def _fail_config(exc: ConfigError) -> None:
    for diag in exc.diagnostics:
        err.print(str(diag), markup=False, soft_wrap=True)
    n = len(exc.diagnostics)
    err.print(f"{n} error{'s' if n != 1 else ''}; nothing was simulated.", style="red")
    raise typer.Exit(EXIT_INVALID)


@app.command()
def run(
    scenario: Annotated[str, typer.Argument(help="Scenario file or bundled name (e.g. pick_place).")],
    seed: Annotated[int, typer.Option(help="Episode seed: randomization and noise.")] = 0,
    as_json: Annotated[bool, typer.Option("--json", help="Print the RunResult as JSON.")] = False,
    set_: Annotated[
        list[str] | None,
        typer.Option("--set", help="Override a blackboard key or scenario value: KEY=VALUE (YAML)."),
    ] = None,
    rrd: Annotated[Path | None, typer.Option(help="Save a Rerun recording to this file.")] = None,
    spawn: Annotated[bool, typer.Option(help="Stream live to a spawned Rerun viewer.")] = False,
) -> None:
    """Run one episode. Exit 0 succeeded, 1 failed, 2 invalid input, 3 aborted by a guard."""
    from .runner import run_episode
    from .scenario_loading import load_scenario

    try:
        loaded = load_scenario(scenario, set_ or [])
        observers = []
        if rrd is not None or spawn:
            from .recording import RerunRecorder

            observers.append(RerunRecorder(path=rrd, spawn=spawn))
        result = run_episode(loaded, seed, observers)
    except ConfigError as exc:
        _fail_config(exc)
        return
    except OrchestratorError as exc:
        err.print(f"error: {exc}", markup=False)
        raise typer.Exit(EXIT_INVALID) from None
    if as_json:
        sys.stdout.write(json.dumps(result.to_json_dict()) + "\n")
    else:
        _print_result(result)
    raise typer.Exit(result.exit_code)


def _print_result(result) -> None:
    style = {"succeeded": "green", "failed": "yellow", "aborted": "red"}[result.outcome]
    out.print(
        f"[bold]{result.scenario}[/] seed {result.seed}: [{style}]{result.outcome}[/] in "
        f"{result.final_state} after {result.sim_time:.2f} s simulated "
        f"({result.wall_time:.2f} s wall, {result.sim_time / max(result.wall_time, 1e-9):.0f}x real time)"
    )
    table = Table("t [s]", "from", "to", "trigger", box=None, pad_edge=False)
    for tr in result.transitions:
        table.add_row(f"{tr['t']:.2f}", tr["from"], tr["to"], tr["trigger"])
    out.print(table)
    if result.reason:
        r = result.reason
        out.print(f"[red]aborted by {r['guard']}[/]: {r['message']} (value {r['value']}, limit {r['limit']})")
    if result.success:
        marks = ", ".join(f"{k} {'ok' if v else 'FAILED'}" for k, v in result.success.items())
        out.print(f"success: {marks}")
    metrics = ", ".join(f"{k} {v}" for k, v in result.metrics.items())
    out.print(f"metrics: {metrics}")
    if result.retries:
        out.print(f"retries: {result.retries}")


@app.command()
def validate(
    paths: Annotated[list[str], typer.Argument(help="Machine or scenario files (or bundled names).")],
) -> None:
    """Check machines and scenarios without simulating: all errors at once, exit 2 if any."""
    from .validate_paths import validate_paths

    problems, checked = validate_paths(paths)
    if problems:
        _fail_config(ConfigError(problems))
    for kind, name in checked:
        out.print(f"ok  {kind:8} {name}")


@app.command(name="list")
def list_() -> None:
    """Bundled scenarios and machines, available skills, guards and robots."""
    from .bundled import bundled_names
    from .guards import GUARDS
    from .robots import ROBOTS
    from .skills import SKILLS, skill_names

    skill_names()
    out.print("[bold]scenarios[/]: " + ", ".join(bundled_names("scenarios")))
    out.print("[bold]machines[/]:  " + ", ".join(bundled_names("machines")))
    table = Table("skill", "outcomes", "description", box=None, pad_edge=False)
    for name in sorted(SKILLS):
        cls = SKILLS[name]
        doc = (cls.__doc__ or "").strip().splitlines()[0]
        table.add_row(name, ", ".join(cls.outcomes), doc)
    out.print(table)
    out.print("[bold]guards[/]:    " + ", ".join(sorted(GUARDS)))
    out.print("[bold]robots[/]:    " + ", ".join(sorted(ROBOTS)))


def main() -> None:
    """Console-script entry point."""
    app()


if __name__ == "__main__":
    main()
