"""`orchestrator explore`: draw variations of a scenario's declared space, run them, shrink
each failure (the campaign itself is orchestrator/explore/)."""

# No `from __future__ import annotations`: typer reads the parameter annotations (options.py).

import sys
from pathlib import Path
from typing import Annotated

import typer

from ..exceptions import ConfigError, OrchestratorError
from .console import err, out, rich_console
from .errors import fail, fail_config
from .options import MAX_SEED, BackendOption, RayAddressOption, WorkersOption

__all__ = ["explore_command"]


def explore_command(
    scenario: Annotated[str, typer.Argument(help="Scenario file or bundled name.")],
    n: Annotated[
        int, typer.Option("-n", "--variations", min=0, help="Variations to draw and run.")
    ] = 20,
    seed: Annotated[
        int,
        typer.Option(
            min=0, max=MAX_SEED, help="The exploration's seed (same seed, same variations)."
        ),  # fmt: skip
    ] = 0,
    workers: WorkersOption = None,
    backend: BackendOption = "local",
    address: RayAddressOption = None,
    out_dir: Annotated[
        Path | None,
        typer.Option(
            "--out", help="Output directory (default: runs/explore-SCENARIO-seedS)."
        ),  # fmt: skip
    ] = None,
    resume: Annotated[
        bool, typer.Option(help="Continue the exploration in --out (same scenario, seed, N).")
    ] = False,
    replay_k: Annotated[
        int | None,
        typer.Option("--replay", min=0, help="Run counterexample K of --out again and exit."),
    ] = None,
    no_shrink: Annotated[
        bool, typer.Option("--no-shrink", help="File each failure as drawn (faster).")
    ] = False,
    max_wall_s: Annotated[
        float, typer.Option(min=0.001, help="Wall-clock limit of one episode [s].")
    ] = 600.0,
    as_json: Annotated[bool, typer.Option("--json", help="Print summary.json only.")] = False,
) -> None:
    """Explore the space a scenario declares valid: draw variations of every parameter with a
    validated range, run them, check the invariants and the success checks, shrink each
    failure to a minimal variation (docs/explore.md). Exit 0 nothing failed, 1 counterexamples
    were found (--replay: it still fails), 2 invalid input."""
    from ..batch.exceptions import BatchError
    from ..batch.progress import NullProgress, RichProgress
    from ..engine.strict_json import dumps
    from ..explore.campaign import ExploreConfig, explore
    from ..explore.replay import replay

    if out_dir is None:
        if replay_k is not None or resume:
            fail("--replay and --resume need --out DIR (the exploration)")
        out_dir = Path("runs") / f"explore-{Path(scenario).stem}-seed{seed}"
    try:
        if replay_k is not None:
            again = replay(out_dir, replay_k, scenario)
            ex = again.example
            out.print(f"counterexample {replay_k}: {ex['violated']} ({ex['message']})",
                      markup=False, soft_wrap=True)  # fmt: skip
            out.print(f"  as a run: {again.command}", markup=False, soft_wrap=True)
            now = ", ".join(again.failures) or "nothing: it passes now"
            out.print(f"  outcome {again.result.outcome}; fails: {now}", markup=False)
            raise typer.Exit(1 if again.failures else 0)
        config = ExploreConfig(scenario, n, out_dir, seed, workers, backend, address, resume,
                               max_wall_s, shrink=not no_shrink)  # fmt: skip
        show = sys.stdout.isatty() and not as_json
        progress = RichProgress(rich_console(out), label=f"explore {Path(scenario).stem}") if (
            show) else NullProgress()  # fmt: skip
        summary = explore(config, progress,
                          warn=lambda m: err.print(f"warning: {m}", markup=False))  # fmt: skip
    except ConfigError as exc:
        fail_config(exc, "nothing was explored")
    except (BatchError, OrchestratorError) as exc:
        fail(str(exc))
    if as_json:
        sys.stdout.write(dumps(summary) + "\n")
    else:
        out.print(f"{summary['scenario']}: {summary['variations']} variations of "
                  f"{summary['parameters']} parameters: {summary['passed']} passed, "
                  f"{summary['failed']} failed, {summary['refused']} refused by the scenario's "
                  f"validation for their seed", markup=False)  # fmt: skip
        for name, count in summary["classes"].items():
            minimal = "; ".join(" + ".join(m) or "(nominal)" for m in
                                summary["minimal_parameters"].get(name, []))  # fmt: skip
            out.print(f"  {name}: {count} (minimal: {minimal})", markup=False, soft_wrap=True)
        out.print(f"counterexamples in {out_dir / 'counterexamples.jsonl'}; re-run one with "
                  f"--replay K --out {out_dir}", markup=False, soft_wrap=True)  # fmt: skip
    raise typer.Exit(1 if summary["counterexamples"] else 0)
