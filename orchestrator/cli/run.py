"""`orchestrator run`: one episode (from its start, or resumed with --from)."""

# No `from __future__ import annotations`: typer reads the parameter annotations of every
# command each time the CLI starts; as strings, each would be compiled and evaluated again
# (cli/__init__.py).
from pathlib import Path
from typing import Annotated

import typer

from ..exceptions import ConfigError, OrchestratorError
from .console import err, json_line
from .errors import EXIT_ERROR, EXIT_INVALID, fail, fail_config
from .options import (
    MAX_SEED,
    AllowPathOption,
    SkillPaths,
    allowed_dirs,
    check_wall,
    check_writable,
    note_entry,
    use_skills,
)
from .results import finish
from .timetravel import checked_break_points, run_from, run_to_break


def run(
    scenario: Annotated[
        str | None,
        typer.Argument(
            help="Scenario file or bundled name (e.g. pick_place), or a machine file: it runs "
            "in the default scene (a Panda, a table, a cube `cube`, a pad `pad`). Optional "
            "with --from (then it must be the snapshot's)."
        ),
    ] = None,
    seed: Annotated[
        int | None,
        typer.Option(
            min=0, max=MAX_SEED, help="Episode seed: randomization and noise (>= 0; default 0)."
        ),
    ] = None,
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
    event: Annotated[
        list[str] | None,
        typer.Option(
            "--event",
            help="Send an event at a simulated time: T:NAME (e.g. 1.5:estop, 1.0:pause, "
            "2.0:resume, or one of the machine's `events:`). Repeatable; see docs/live.md.",
        ),
    ] = None,
    connect: Annotated[
        str | None,
        typer.Option(
            help="Stream live to a running Rerun viewer or `rerun --serve-web`: "
            "rerun+http://HOST:PORT/proxy or a port."
        ),
    ] = None,
    max_wall_s: Annotated[
        float | None,
        typer.Option(
            min=0.001,
            help="Wall-clock limit [s]: past it the machine is halted, the arm brought to rest "
            "and the run ends `error` (exit 4) with the reason (default: no limit).",
        ),
    ] = None,
    allow_path: AllowPathOption = None,
    skills: SkillPaths = None,
    debug: Annotated[
        bool, typer.Option("--debug", help="A skill that raises: print its traceback too.")
    ] = False,
    break_: Annotated[
        list[str] | None,
        typer.Option(
            "--break",
            help="Stop at this state's entry and write a snapshot: a state's dotted path or "
            "its last part (GRASP, PICK.GRASP), STATE@N for its N-th entry. Repeatable: the "
            "first reached stops. Exit 6. See docs/time-travel.md.",
        ),
    ] = None,
    break_on: Annotated[
        list[str] | None,
        typer.Option(
            "--break-on",
            help="Stop where a guard aborts the run and write a snapshot: `guard` (any), a "
            "guard's name or `estop`. Repeatable. Exit 6.",
        ),
    ] = None,
    break_at: Annotated[
        float | None,
        typer.Option(
            "--break-at",
            help="Stop at the first control tick at or after this simulated time [s] and "
            "write a snapshot. Exit 6.",
        ),
    ] = None,
    from_: Annotated[
        Path | None,
        typer.Option(
            "--from",
            help="Resume a snapshot: the run continues bit for bit as it would have; --set "
            "changes blackboard keys first.",
        ),
    ] = None,
    snapshot: Annotated[
        Path | None,
        typer.Option(
            "--snapshot",
            help="Where --break writes the snapshot (default: SCENARIO-seedS-tickN.snap here).",
        ),
    ] = None,
    strict: Annotated[bool, typer.Option(help="Exit 1 on an invariant violation.")] = False,
) -> None:
    """Run one episode. Exit 0 succeeded, 1 failed, 2 invalid
    input, 3 aborted by a guard, 4 outcome `error`: a skill raised or --max-wall-s passed (the
    arm is brought to rest; the skill's file:line and exception are printed, the traceback with
    --debug), 141 stdout closed by its reader (README's table), 6 stopped
    at a break point (--break, --break-on, --break-at: the snapshot's path is printed)."""
    from ..engine.prepare import prepare
    from ..engine.runner import WallTimeExceeded
    from ..language.entries import file_kind

    check_wall(max_wall_s)
    if rrd is not None:
        check_writable(rrd, "--rrd")
    breaking = bool(break_ or break_on or break_at is not None)
    if breaking and rrd is not None:
        fail("--rrd records a run to its end: record the resumed run (--from SNAPSHOT --rrd)")
    if snapshot is not None:
        if not breaking:
            fail("--snapshot names the file a break point writes: give --break STATE too")
        check_writable(snapshot, "--snapshot")
    use_skills(skills)
    if from_ is not None:
        run_from(
            from_, scenario, seed, set_ or [], fault or [], event or [], as_json, rrd, spawn,
            connect, max_wall_s, debug, (break_ or [], break_on or [], break_at), snapshot,
        )  # fmt: skip
        return
    if scenario is None:
        fail("give a SCENARIO to run, or --from SNAPSHOT to resume one")
        return
    seed = seed if seed is not None else 0
    note_entry(scenario)
    if file_kind(scenario) == ("machine", scenario):
        err.print(
            f"{scenario} is a machine: running it in the default scene (Panda, table, cube "
            "`cube`, pad `pad`; docs/scenario-reference.md to write a scenario)",
            markup=False,
            soft_wrap=True,
        )
    try:
        prepared = prepare(
            scenario, seed, set_ or [], fault or [], event or [], allowed_dirs(allow_path)
        )
        if breaking:
            points = checked_break_points(
                prepared.loaded.machine, break_ or [], break_on or [], break_at
            )
            run_to_break(prepared.new_run, points, snapshot, as_json, debug)
            return
        observers = []
        if rrd is not None or spawn or connect is not None:
            from ..recording import RerunRecorder

            observers.append(RerunRecorder(path=rrd, spawn=spawn, connect=connect))
        result = prepared.run_episode(observers, max_wall_s)
    except ConfigError as exc:
        fail_config(exc)
        return
    except WallTimeExceeded as exc:
        if as_json:
            line = exc.result.to_json_dict()
            line["outcome"] = "error"
            line["error"] = {"type": type(exc).__name__, "message": str(exc), "traceback": None}
            json_line(line)
        err.print(f"error: {exc}", markup=False, soft_wrap=True)
        raise typer.Exit(EXIT_ERROR) from None
    except OrchestratorError as exc:
        err.print(f"error: {exc}", markup=False)
        raise typer.Exit(EXIT_INVALID) from None
    finish(result, as_json, debug, rrd, strict)
