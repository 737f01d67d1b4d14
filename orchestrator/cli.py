"""The `orchestrator` command line (the acceptance checks call exactly this)."""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Annotated, Literal

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
    what = "the run was stopped" if exc.during_run else "nothing was simulated"
    err.print(f"{n} error{'s' if n != 1 else ''}; {what}.", style="red")
    raise typer.Exit(EXIT_INVALID)


@app.command()
def run(
    scenario: Annotated[
        str, typer.Argument(help="Scenario file or bundled name (e.g. pick_place).")
    ],
    seed: Annotated[int, typer.Option(help="Episode seed: randomization and noise.")] = 0,
    as_json: Annotated[bool, typer.Option("--json", help="Print the RunResult as JSON.")] = False,
    set_: Annotated[
        list[str] | None,
        typer.Option(
            "--set", help="Override a blackboard key or scenario value: KEY=VALUE (YAML)."
        ),
    ] = None,
    rrd: Annotated[Path | None, typer.Option(help="Save a Rerun recording to this file.")] = None,
    spawn: Annotated[bool, typer.Option(help="Stream live to a spawned Rerun viewer.")] = False,
    fault: Annotated[
        list[str] | None,
        typer.Option(
            "--fault",
            help="Inject a fault: KIND[:KEY=VALUE,...]@WHEN, WHEN a time [s] or a state "
            "(e.g. estop@1.5, slip:object=cube@TRANSPORT). Repeatable; see docs/safety.md.",
        ),
    ] = None,
    connect: Annotated[
        str | None,
        typer.Option(
            help="Stream live to a running Rerun viewer or `rerun --serve-web`: "
            "rerun+http://HOST:PORT/proxy or a port."
        ),
    ] = None,
) -> None:
    """Run one episode. Exit 0 succeeded, 1 failed, 2 invalid input, 3 aborted by a guard."""
    from .engine.runner import run_episode
    from .language.load import load_scenario

    try:
        loaded = load_scenario(scenario, set_ or [], fault or [])
        observers = []
        if rrd is not None or spawn or connect is not None:
            from .recording import RerunRecorder

            observers.append(RerunRecorder(path=rrd, spawn=spawn, connect=connect))
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
    rtf = result.sim_time / max(result.wall_time, 1e-9)
    out.print(
        f"[bold]{result.scenario}[/] seed {result.seed}: [{style}]{result.outcome}[/] in "
        f"{result.final_state} after {result.sim_time:.2f} s simulated "
        f"({result.wall_time:.2f} s wall, {rtf:.0f}x real time)"
    )
    table = Table("t [s]", "from", "to", "trigger", box=None, pad_edge=False)
    for tr in result.transitions:
        table.add_row(f"{tr['t']:.2f}", tr["from"], tr["to"], tr["trigger"])
    out.print(table)
    if result.reason:
        r = result.reason
        out.print(
            f"[red]aborted by {r['guard']}[/]: {r['message']} "
            f"(value {r['value']}, limit {r['limit']})"
        )
    if result.success:
        marks = ", ".join(f"{k} {'ok' if v else 'FAILED'}" for k, v in result.success.items())
        out.print(f"success: {marks}")
    metrics = ", ".join(f"{k} {v}" for k, v in result.metrics.items())
    out.print(f"metrics: {metrics}")
    if result.retries:
        out.print(f"retries: {result.retries}")


@app.command()
def faults(
    scenario: Annotated[str, typer.Argument(help="Scenario file or bundled name.")],
    seed: Annotated[int, typer.Option(help="The seed every row runs.")] = 0,
    as_json: Annotated[bool, typer.Option("--json", help="Print the rows as JSON.")] = False,
    set_: Annotated[
        list[str] | None,
        typer.Option("--set", help="Override a blackboard key or scenario value (KEY=VALUE)."),
    ] = None,
) -> None:
    """The fault matrix: one run per fault type, the guard that caught it and the stop.
    Exit 0 when every row met its expectation, 1 otherwise, 2 invalid input."""
    from .batch.fault_matrix import RowResult, run_matrix

    def progress(row: RowResult) -> None:
        if not as_json:
            err.print(f"  {row.fault}: {row.outcome}", markup=False)

    try:
        rows = run_matrix(scenario, seed, set_ or [], on_row=progress)
    except ConfigError as exc:
        _fail_config(exc)
        return
    if as_json:
        sys.stdout.write(json.dumps([r.to_dict() for r in rows]) + "\n")
    else:
        table = Table(
            "fault", "expected", "guard", "exit", "detect [s]", "stop [s]", "stop [mm]", "",
            box=None, pad_edge=False,
        )  # fmt: skip
        for r in rows:
            mark = {True: "[green]ok[/]", False: "[red]MISMATCH[/]", None: ""}[r.ok]
            table.add_row(
                r.fault,
                r.expect or "-",
                r.guard or "-",
                str(r.exit_code),
                "-" if r.detect_s is None else f"{r.detect_s:.3f}",
                "-" if r.stop_time_s is None else f"{r.stop_time_s:.3f}",
                "-" if r.stop_distance_mm is None else f"{r.stop_distance_mm:.1f}",
                mark,
            )
        out.print(table)
    raise typer.Exit(0 if all(r.ok is not False for r in rows) else 1)


@app.command()
def validate(
    paths: Annotated[
        list[str], typer.Argument(help="Machine or scenario files (or bundled names).")
    ],
) -> None:
    """Check machines and scenarios without simulating: all errors at once, exit 2 if any."""
    from .language.validate_paths import validate_paths

    problems, checked = validate_paths(paths)
    if problems:
        _fail_config(ConfigError(problems))
    for kind, name in checked:
        out.print(f"ok  {kind:8} {name}")


@app.command()
def graph(
    machine: Annotated[str, typer.Argument(help="Machine file or bundled name.")],
    fmt: Annotated[
        str, typer.Option("--format", help="mermaid (no system package needed) or dot (Graphviz).")
    ] = "mermaid",
) -> None:
    """Draw a machine: states, outcome-labelled transitions, nested clusters, the abort path."""
    from .language.graph import to_dot, to_mermaid
    from .language.load import load_machine

    if fmt not in ("mermaid", "dot"):
        err.print(f"--format: unknown format {fmt!r} (valid: mermaid, dot)")
        raise typer.Exit(EXIT_INVALID)
    try:
        node = load_machine(machine)
    except ConfigError as exc:
        _fail_config(exc)
        return
    sys.stdout.write(to_mermaid(node) if fmt == "mermaid" else to_dot(node))


@app.command()
def schema(
    kind: Annotated[str, typer.Argument(help="machine or scenario")],
) -> None:
    """Print the JSON Schema (draft 7) of machine or scenario files, for yaml-language-server."""
    from .language.schema_gen import schema_text

    if kind not in ("machine", "scenario"):
        err.print(f"unknown schema {kind!r} (valid: machine, scenario)")
        raise typer.Exit(EXIT_INVALID)
    sys.stdout.write(schema_text(kind))


@app.command(name="list")
def list_() -> None:
    """Bundled scenarios and machines, available skills, guards and robots."""
    from .guards import GUARDS
    from .language.bundled import bundled_names
    from .robots import ROBOTS
    from .skills import SKILLS, skill_names

    skill_names()
    out.print("[bold]scenarios[/]: " + ", ".join(bundled_names("scenarios")))
    out.print("[bold]machines[/]:  " + ", ".join(bundled_names("machines")))
    table = Table("skill", "outcomes", "description", box=None, pad_edge=False)
    for name in sorted(SKILLS):
        cls = SKILLS[name]
        text = " ".join((cls.__doc__ or "").split())
        doc = text.split(". ")[0].rstrip(".") + "." if text else ""
        table.add_row(name, ", ".join(cls.outcomes), doc)
    out.print(table)
    out.print("[bold]guards[/]:    " + ", ".join(sorted(GUARDS)))
    out.print("[bold]robots[/]:    " + ", ".join(sorted(ROBOTS)))
    from .perception.backends import backend_status

    out.print("[bold]camera renderer[/]: " + backend_status().describe())


@app.command()
def batch(
    scenario: Annotated[str, typer.Argument(help="Scenario file or bundled name.")],
    episodes: Annotated[int, typer.Option("-n", "--episodes", min=1, help="Number of episodes.")],
    seed_base: Annotated[int, typer.Option(help="Episode i runs seed SEED_BASE + i.")] = 0,
    workers: Annotated[
        int | None, typer.Option(min=1, help="Worker processes / Ray CPUs (default: every core).")
    ] = None,
    backend: Annotated[
        Literal["local", "ray"], typer.Option(help="Local worker processes, or Ray tasks.")
    ] = "local",
    address: Annotated[
        str | None, typer.Option(help="Ray address (default: $RAY_ADDRESS, else a local Ray).")
    ] = None,
    out_dir: Annotated[
        Path | None, typer.Option("--out", help="Batch directory (default: runs/SCENARIO-TIME).")
    ] = None,
    resume: Annotated[bool, typer.Option(help="Skip seeds already in DIR/results.jsonl.")] = False,
    as_json: Annotated[bool, typer.Option("--json", help="Print summary.json only.")] = False,
    set_: Annotated[
        list[str] | None,
        typer.Option("--set", help="Override a blackboard key or scenario value (KEY=VALUE)."),
    ] = None,
    record: Annotated[
        Literal["failures", "all", "none"] | None,
        typer.Option(help="Save DIR/episodes/seed_S.rrd for these episodes (default: failures)."),
    ] = None,
) -> None:
    """Run N seeded episodes in parallel: exit 0 all ran, 1 some raised, 2 invalid input."""
    import time as _time

    from .batch import BatchConfig, BatchError, run_batch
    from .batch.progress import NullProgress, RichProgress
    from .batch.report import print_summary

    if resume and out_dir is None:
        err.print("error: --resume needs --out DIR (the batch to continue)", markup=False)
        raise typer.Exit(EXIT_INVALID)
    if out_dir is None:
        out_dir = Path("runs") / f"{Path(scenario).stem}-{_time.strftime('%Y%m%d-%H%M%S')}"
    config = BatchConfig(
        scenario=scenario,
        episodes=episodes,
        out_dir=out_dir,
        seed_base=seed_base,
        workers=workers,
        backend=backend,
        address=address,
        resume=resume,
        overrides=tuple(set_ or ()),
        record=record,
    )
    show = sys.stdout.isatty() and not as_json
    progress = RichProgress(out, label=Path(scenario).stem) if show else NullProgress()

    def warn(message: str) -> None:
        err.print(f"warning: {message}", markup=False, soft_wrap=True)

    try:
        summary = run_batch(config, progress, warn=warn)
    except ConfigError as exc:
        _fail_config(exc)
        return
    except (BatchError, OrchestratorError) as exc:
        err.print(f"error: {exc}", markup=False, soft_wrap=True)
        raise typer.Exit(EXIT_INVALID) from None
    except KeyboardInterrupt:
        err.print(
            f"interrupted; finished episodes are in {out_dir / 'results.jsonl'}: continue "
            f"with the same command plus --resume --out {out_dir}",
            markup=False,
            soft_wrap=True,
        )
        raise typer.Exit(130) from None
    if as_json:
        sys.stdout.write(json.dumps(summary.to_json_dict()) + "\n")
    else:
        print_summary(summary, out)
    raise typer.Exit(1 if summary.errors else 0)


def main() -> None:
    """Console-script entry point."""
    app()


if __name__ == "__main__":
    main()
