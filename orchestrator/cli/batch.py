"""Many episodes: `batch` (N seeded episodes in parallel) and `faults` (the fault matrix)."""

# No `from __future__ import annotations`: typer reads the parameter annotations of every
# command each time the CLI starts; as strings, each would be compiled and evaluated again
# (cli/__init__.py).
import sys
from pathlib import Path
from typing import Annotated, Literal

import typer

from ..exceptions import ConfigError, OrchestratorError
from .console import err, escape, json_line, out, rich_console
from .errors import EXIT_INVALID, fail, fail_config
from .options import (
    MAX_SEED,
    AllowPathOption,
    BackendOption,
    RayAddressOption,
    SeedOption,
    SkillPaths,
    WorkersOption,
    allowed_dirs,
    check_wall,
    note_entry,
    use_skills,
)


def faults(
    scenario: Annotated[str, typer.Argument(help="Scenario file or bundled name.")],
    seed: SeedOption = 0,
    as_json: Annotated[bool, typer.Option("--json", help="Print the rows as JSON.")] = False,
    set_: Annotated[
        list[str] | None,
        typer.Option("--set", help="Override a blackboard key or scenario value (KEY=VALUE)."),
    ] = None,
    skills: SkillPaths = None,
) -> None:
    """The fault matrix: one run per fault type, the guard that caught it and the stop.
    Exit 0 when every row met its expectation, 1 otherwise, 2 invalid input."""
    from rich.table import Table

    from ..batch.fault_matrix import RowResult, run_matrix

    note_entry(scenario)
    use_skills(skills)

    def progress(row: RowResult) -> None:
        if not as_json:
            err.print(f"  {row.fault}: {row.outcome}", markup=False)

    try:
        rows = run_matrix(scenario, seed, set_ or [], on_row=progress)
    except ConfigError as exc:
        fail_config(exc)
        return
    if as_json:
        json_line([r.to_dict() for r in rows])
    else:
        table = Table(
            "fault", "expected", "guard", "exit", escape("detect [s]"),
            escape("stop time [s]"), escape("stop distance [mm]"), "",
            box=None, pad_edge=False,
        )  # fmt: skip
        for r in rows:
            mark = {True: "[green]ok[/]", False: "[red]MISMATCH[/]", None: ""}[r.ok]
            table.add_row(
                escape(r.fault),
                escape(r.expect or "-"),
                escape(r.guard or "-"),
                str(r.exit_code),
                "-" if r.detect_s is None else f"{r.detect_s:.3f}",
                "-" if r.stop_time_s is None else f"{r.stop_time_s:.3f}",
                "-" if r.stop_distance_mm is None else f"{r.stop_distance_mm:.1f}",
                mark,
            )
        out.print(table)
        undetected = sum(r.undetected for r in rows)
        blind = sum(r.blind for r in rows)
        out.print(
            f"{len(rows)} faults: {sum(r.ok is True for r in rows)} as expected, "
            f"{undetected} undetected"
            + (f", {blind} no guard of the scenario can see" * bool(blind)),
            markup=False,
        )
    _warn_blind(rows)
    raise typer.Exit(0 if all(r.ok is not False for r in rows) else 1)


def _warn_blind(rows) -> None:
    """Say which fault kinds the scenario's guards cannot detect, and which guard would."""
    from ..batch.fault_matrix import DETECTED_BY, fault_kind

    kinds = list(dict.fromkeys(fault_kind(r.fault) for r in rows if r.blind))
    if kinds:
        which = "; ".join(f"{k} (needs {' or '.join(DETECTED_BY[k])})" for k in kinds)
        err.print(
            f"warning: no guard of this scenario can detect these fault kinds: {which}; add "
            "the guard to its `guards:` to have them caught",
            markup=False,
            soft_wrap=True,
        )


def batch(
    scenario: Annotated[str, typer.Argument(help="Scenario file or bundled name.")],
    episodes: Annotated[int, typer.Option("-n", "--episodes", min=1, help="Number of episodes.")],
    seed_base: Annotated[
        int, typer.Option(min=0, max=MAX_SEED, help="Episode i runs seed SEED_BASE + i (>= 0).")
    ] = 0,
    workers: WorkersOption = None,
    backend: BackendOption = "local",
    address: RayAddressOption = None,
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
    max_wall_s: Annotated[
        float | None,
        typer.Option(
            min=0.001,
            help="Wall-clock limit of one episode [s] (default 600): past it the episode is "
            "stopped and recorded as `error` with the reason.",
        ),
    ] = None,
    allow_path: AllowPathOption = None,
    snapshot_on_failure: Annotated[
        bool,
        typer.Option(
            "--snapshot-on-failure",
            help="Keep DIR/snapshots/seed_S.snap for each episode that does not succeed: the "
            "snapshot at its last state entry before the failure (`run --from` resumes it).",
        ),
    ] = False,
    skills: SkillPaths = None,
    strict: Annotated[
        bool, typer.Option(help="Exit 1 if an episode violates an invariant.")
    ] = False,
) -> None:
    """Run N seeded episodes in parallel: exit 0 all ran, 1 some raised or (--strict) violated
    an invariant, 2 invalid input."""
    import time as _time

    from ..batch import BatchConfig, BatchError, run_batch
    from ..batch.config import DEFAULT_MAX_WALL_S
    from ..batch.progress import NullProgress, RichProgress
    from ..batch.report import print_summary

    check_wall(max_wall_s)
    note_entry(scenario)
    use_skills(skills)
    if seed_base + episodes - 1 > MAX_SEED:
        fail(f"--seed-base {seed_base} + -n {episodes} runs past the largest seed {MAX_SEED}")
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
        max_wall_s=DEFAULT_MAX_WALL_S if max_wall_s is None else max_wall_s,
        allow_paths=tuple(str(p) for p in allowed_dirs(allow_path)),
        snapshot_on_failure=snapshot_on_failure,
        skill_paths=tuple(str(p.resolve()) for p in skills or ()),
    )
    show = sys.stdout.isatty() and not as_json
    progress = (
        RichProgress(rich_console(out), label=Path(scenario).stem) if show else NullProgress()
    )

    def warn(message: str) -> None:
        err.print(f"warning: {message}", markup=False, soft_wrap=True)

    try:
        summary = run_batch(config, progress, warn=warn)
    except ConfigError as exc:
        fail_config(exc)
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
        json_line(summary.to_json_dict())
    else:
        print_summary(summary, rich_console(out))
    if strict:  # docs/invariants.md
        from ..batch.store import ResultsStore
        from ..engine.invariants import violated_names

        names = violated_names(list(ResultsStore(out_dir).load().values()))
        for name, n in names.items():
            err.print(f"invariant {name} violated in {n} episodes", markup=False)
        if names:
            raise typer.Exit(1)
    raise typer.Exit(1 if summary.errors else 0)
