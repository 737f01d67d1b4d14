"""The `orchestrator` command line (the acceptance checks call exactly this)."""

# No `from __future__ import annotations` in this module: typer reads the parameter annotations
# of every command each time the CLI starts (even for `--version`); as strings, each would be
# compiled and evaluated: 15 % of `--version`'s instructions, 5 % of `validate`'s.
import functools
import math
import os
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any, Literal, cast

import typer

from .exceptions import ConfigError, OrchestratorError

__all__ = ["app", "main"]

app = typer.Typer(
    name="orchestrator",
    help="Run declarative YAML robot task flows on MuJoCo physics.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)
if TYPE_CHECKING:
    from rich.console import Console

# Whatever a user file holds can reach these consoles (state names, messages, paths): no
# emoji codes (`:100:` in `file:100:7` would print as an emoji), no highlighting, and every
# user string passes `markup=False` or `escape()`.
_WIDE = 1000
"""Console width when the output is not a terminal: a pipe or a file gets unwrapped lines."""


class _LazyConsole:
    """A rich `Console`, made when first used: `--version` and a clean `validate` print plain
    lines (`_plain`) and do not import rich (its console and markup are ~8 % of `validate`'s
    instructions)."""

    def __init__(self, stderr: bool) -> None:
        self._stderr = stderr

    @functools.cached_property
    def _console(self) -> "Console":
        from rich.console import Console

        tty = (sys.stderr if self._stderr else sys.stdout).isatty()
        return Console(
            stderr=self._stderr, highlight=False, emoji=False, width=None if tty else _WIDE
        )

    def __getattr__(self, name: str) -> Any:
        return getattr(self._console, name)


err = cast("Console", _LazyConsole(stderr=True))
out = cast("Console", _LazyConsole(stderr=False))


def _rich(console: "Console") -> "Console":
    """The rich `Console` behind `out` or `err`, for code that is handed it: rich's `Live` (a
    progress bar, `watch`) enters it as a context manager, which a stand-in cannot be."""
    lazy = cast(Any, console)
    return lazy._console if isinstance(lazy, _LazyConsole) else console


_CONTROL = {c: f"\\x{c:02x}" for c in (*range(0x20), 0x7F, *range(0x80, 0xA0)) if c != 0x09}
"""Control characters, written as escapes by `_plain` (a file name cannot move the cursor)."""


def _plain(line: str) -> None:
    """One line on stdout as it is, control characters escaped (no rich needed)."""
    sys.stdout.write(line.translate(_CONTROL) + "\n")


def escape(text: str) -> str:
    """`text` with rich's markup escaped (rich.markup.escape, imported when first needed)."""
    from rich.markup import escape as rich_escape

    return rich_escape(text)


EXIT_INVALID = 2
EXIT_BREAK = 6
"""`run --break ...` stopped at a break point and wrote its snapshot."""
EXIT_ERROR = 4
"""Outcome `error`: a skill raised, or the run went past `--max-wall-s` (README's table)."""
EXIT_PIPE = 141
"""Whoever read stdout closed it (`| head -c1`): what a shell reports for SIGPIPE (128 + 13)."""
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


def _strict_json(value: object) -> str:
    """`value` as strict JSON: non-finite numbers as null (engine/strict_json.py)."""
    from .engine.strict_json import dumps

    return dumps(value)


def _json_line(value: object) -> None:
    """Print one strict JSON document on stdout (what every `--json` prints)."""
    sys.stdout.write(_strict_json(value) + "\n")


def _fail(message: str) -> None:
    """One clean line on stderr, exit 2."""
    err.print(f"error: {message}", markup=False, soft_wrap=True)
    raise typer.Exit(EXIT_INVALID)


def _allowed(paths: list[Path] | None) -> tuple[Path, ...]:
    """The `--allow-path` directories, each checked to be one."""
    for path in paths or ():
        if not path.is_dir():
            what = "does not exist" if not path.exists() else "is not a directory"
            _fail(f"--allow-path {path}: {what} (give a directory that holds machine files)")
    return tuple(paths or ())


def _check_wall(max_wall_s: float | None) -> None:
    if max_wall_s is not None and not math.isfinite(max_wall_s):
        _fail(f"--max-wall-s {max_wall_s}: give a finite number of seconds (omit it for no limit)")


def _is_dir(path: Path) -> bool:
    """`path.is_dir()`, False for names the system refuses (too long, a NUL byte)."""
    try:
        return path.is_dir()
    except (OSError, ValueError):
        return False


def _check_writable(path: Path, option: str) -> None:
    """Refuse an output file that cannot be written, before anything runs. Its folder must
    exist: a mistyped path is said, never created (`/nonexistent/dir` is not made)."""
    if _is_dir(path):
        _fail(f"{option} {path}: is a directory; give a file name, e.g. {path / 'run.rrd'}")
    parent = path.parent if str(path.parent) else Path(".")
    if not _is_dir(parent):
        if os.path.exists(parent):  # False, not an error, for a name the system refuses
            _fail(f"{option} {path}: {parent} is not a folder; give a file in a folder")
        _fail(f"{option} {path}: the folder {parent} does not exist: create it first, or give "
              "a file in a folder that exists")  # fmt: skip
    existed = path.exists()
    try:
        with path.open("ab"):
            pass
    except OSError as exc:
        _fail(f"{option} {path}: cannot write it ({exc.strerror})")
    if not existed:
        path.unlink(missing_ok=True)


SkillPaths = Annotated[
    list[Path] | None,
    typer.Option(
        "--skills",
        help="A folder (or .py file) of your own skill modules (and success checks), no "
        "package needed: imported (its code runs), as you name it. Repeatable.",
    ),
]


def _version(value: bool) -> None:
    if value:
        from importlib.metadata import version

        from .world.native import native

        # which path runs the per-step arithmetic: the compiled extension or its Python twin
        step = "compiled" if native() is not None else "pure Python"
        _plain(f"orchestrator {version('embodied-orchestrator')} (physics step: {step})")
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
_warned = False


def _use_skills(paths: list[Path] | None) -> None:
    """Register `--skills` folders (their skills and success checks), discover plugins and
    say which plugins were skipped."""
    global _warned  # noqa: PLW0603 - print plugin warnings once per process
    from .skills import PLUGIN_WARNINGS, SkillLoadError, skill_names
    from .success import check_kinds, register_plugin_path

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


def _note_entry(ref: str) -> None:
    """Say which one a SCENARIO argument means when it could mean a file or a bundled name
    (the rule: language/entries.py)."""
    from .language.entries import entry_note

    note = entry_note(ref)
    if note is not None:
        err.print(f"note: {note}", markup=False, soft_wrap=True)


def _fail_config(exc: ConfigError, what: str = "nothing was simulated") -> None:
    from .language.diagnostics import collapse

    diagnostics = collapse(exc.diagnostics)  # one mistake said once, with where else it is
    for diag in diagnostics:
        err.print(str(diag), markup=False, soft_wrap=True)
    n = len(diagnostics)
    what = "the run was stopped" if exc.during_run else what
    err.print(f"{n} error{'s' if n != 1 else ''}; {what}.", style="red")
    raise typer.Exit(EXIT_INVALID)


@app.command()
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
    from .engine.prepare import prepare
    from .engine.runner import WallTimeExceeded
    from .language.entries import file_kind

    _check_wall(max_wall_s)
    if rrd is not None:
        _check_writable(rrd, "--rrd")
    breaking = bool(break_ or break_on or break_at is not None)
    if breaking and rrd is not None:
        _fail("--rrd records a run to its end: record the resumed run (--from SNAPSHOT --rrd)")
    if snapshot is not None:
        if not breaking:
            _fail("--snapshot names the file a break point writes: give --break STATE too")
        _check_writable(snapshot, "--snapshot")
    _use_skills(skills)
    if from_ is not None:
        _run_from(
            from_, scenario, seed, set_ or [], fault or [], event or [], as_json, rrd, spawn,
            connect, max_wall_s, debug, (break_ or [], break_on or [], break_at), snapshot,
        )  # fmt: skip
        return
    if scenario is None:
        _fail("give a SCENARIO to run, or --from SNAPSHOT to resume one")
        return
    seed = seed if seed is not None else 0
    _note_entry(scenario)
    if file_kind(scenario) == ("machine", scenario):
        err.print(
            f"{scenario} is a machine: running it in the default scene (Panda, table, cube "
            "`cube`, pad `pad`; docs/scenario-reference.md to write a scenario)",
            markup=False,
            soft_wrap=True,
        )
    try:
        prepared = prepare(
            scenario, seed, set_ or [], fault or [], event or [], _allowed(allow_path)
        )
        if breaking:
            points = _break_points(prepared.loaded.machine, break_ or [], break_on or [], break_at)
            _break(prepared.new_run, points, snapshot, as_json, debug)
            return
        observers = []
        if rrd is not None or spawn or connect is not None:
            from .recording import RerunRecorder

            observers.append(RerunRecorder(path=rrd, spawn=spawn, connect=connect))
        result = prepared.run_episode(observers, max_wall_s)
    except ConfigError as exc:
        _fail_config(exc)
        return
    except WallTimeExceeded as exc:
        if as_json:
            line = exc.result.to_json_dict()
            line["outcome"] = "error"
            line["error"] = {"type": type(exc).__name__, "message": str(exc), "traceback": None}
            _json_line(line)
        err.print(f"error: {exc}", markup=False, soft_wrap=True)
        raise typer.Exit(EXIT_ERROR) from None
    except OrchestratorError as exc:
        err.print(f"error: {exc}", markup=False)
        raise typer.Exit(EXIT_INVALID) from None
    if as_json:
        _json_line(result.to_json_dict())
    else:
        _print_result(result)
    if result.error is not None:
        _print_skill_fault(result.error, debug)
    if rrd is not None:
        err.print(f"recording saved to {rrd} (open it with: rerun {rrd})", markup=False)
    violation = result.strict_violation if strict else None
    if violation is not None:  # --strict: docs/invariants.md
        err.print(f"invariant {violation['invariant']} violated: {violation['message']}",
                  markup=False, soft_wrap=True)  # fmt: skip
        raise typer.Exit(1)
    raise typer.Exit(result.exit_code)


_TABLE_ENDS = 20
"""Transitions printed at each end of a long run's table."""


def _break_points(machine, states: list[str], guards: list[str], at_t: float | None):
    """The break points of the options, checked against `machine` (exit 2 otherwise)."""
    from .engine.snapshot.breaks import break_points

    try:
        return break_points(machine, states, guards, at_t)
    except ConfigError as exc:
        _fail_config(exc)
        raise  # unreachable: _fail_config exits


def _break(make_run, points, out: Path | None, as_json: bool, debug: bool) -> None:
    """Run to the first break point and write its snapshot (exit 6), or to the end if none is
    reached (its exit code)."""
    from .engine.snapshot import Broken, SnapshotError, break_run

    try:
        broken = break_run(make_run, points, out)
    except SnapshotError as exc:
        _fail(str(exc))
        return
    if not isinstance(broken, Broken):  # the run ended first: its result
        result = broken
        options = ", ".join(p.option for p in points)
        err.print(f"no break point was reached ({options}): the run ended", markup=False)
        _finish(result, as_json, debug, None)
        return
    if as_json:
        _json_line(broken.to_json_dict())
    info = broken.to_json_dict()
    err.print(
        f"snapshot written to {broken.path} ({broken.size / 1e6:.2f} MB): "
        f"{info['scenario']} seed {info['seed']} stopped at t={info['t']:.3f} s, tick "
        f"{info['tick']}, the start of the tick of the {broken.stop.reason} "
        f"({broken.stop.option}); resume with: orchestrator run --from {broken.path}",
        markup=False,
        soft_wrap=True,
    )
    raise typer.Exit(EXIT_BREAK)


def _run_from(
    path: Path,
    scenario: str | None,
    seed: int | None,
    sets: list[str],
    faults: list[str],
    events: list[str],
    as_json: bool,
    rrd: Path | None,
    spawn: bool,
    connect: str | None,
    max_wall_s: float | None,
    debug: bool,
    breaks: tuple[list[str], list[str], float | None],
    snapshot: Path | None,
) -> None:
    """`run --from SNAPSHOT`: resume it (and break again, if asked)."""
    from .engine.prepare import check_resumed_goals
    from .engine.runner import WallTimeExceeded, drive
    from .engine.snapshot import SnapshotError, open_run

    if faults or events:
        _fail(
            "--fault and --event shape a run from its start: a resumed run has its snapshot's "
            "(run the scenario again with them, and --break where you want)"
        )
    try:
        opened = open_run(path, scenario, seed, sets)
    except SnapshotError as exc:
        _fail(str(exc))
        return
    except ConfigError as exc:
        _fail_config(exc, "nothing was resumed")
        return
    run = opened.run
    try:
        check_resumed_goals(run, sets)
    except ConfigError as exc:
        _fail_config(exc, "nothing was resumed")
    states, guards, at_t = breaks
    if states or guards or at_t is not None:
        points = _break_points(run.loaded.machine, states, guards, at_t)
        first = [run]

        def again():  # the snapshot read back once more for the second pass
            if first:
                return first.pop()
            return open_run(path, scenario, seed, sets).run

        _break(again, points, snapshot, as_json, debug)
        return
    h = opened.header
    state = h.get("state") or "before the initial state"
    err.print(
        f"resumed {h.get('scenario')} seed {h.get('seed')} from {path} at t={h.get('t'):.3f} s "
        f"(tick {h.get('tick')}, {state}; {(h.get('break') or {}).get('reason', '')}), read "
        f"in {opened.load_s:.2f} s",
        markup=False,
        soft_wrap=True,
    )
    observers = []
    if rrd is not None or spawn or connect is not None:
        from .recording import RerunRecorder

        observers.append(RerunRecorder(path=rrd, spawn=spawn, connect=connect))
    try:
        result = drive(run, observers, max_wall_s)
    except ConfigError as exc:
        _fail_config(exc)
        return
    except WallTimeExceeded as exc:
        err.print(f"error: {exc}", markup=False, soft_wrap=True)
        raise typer.Exit(EXIT_ERROR) from None
    assert result is not None
    _finish(result, as_json, debug, rrd)


def _finish(result, as_json: bool, debug: bool, rrd: Path | None) -> None:
    """Print a run's result and exit with its code."""
    if as_json:
        _json_line(result.to_json_dict())
    else:
        _print_result(result)
    if result.error is not None:
        _print_skill_fault(result.error, debug)
    if rrd is not None:
        err.print(f"recording saved to {rrd} (open it with: rerun {rrd})", markup=False)
    raise typer.Exit(result.exit_code)


def _print_skill_fault(error: dict, debug: bool) -> None:
    """A skill raised: one line (skill, file:line, exception), the traceback with --debug."""
    from .engine.skill_fault import SkillFault

    fault = SkillFault(**error)
    hint = "" if debug else "; --debug prints the traceback"
    line = f"error: {fault.line()}; the arm was brought to rest and held (exit 4{hint})"
    err.print(line, markup=False, soft_wrap=True)
    if debug:
        err.print(fault.traceback.rstrip(), markup=False, soft_wrap=True)


def _print_result(result) -> None:
    style = {"succeeded": "green", "failed": "yellow", "aborted": "red", "error": "red"}[
        result.outcome
    ]
    from rich.table import Table  # here: `--version` and `validate` print no table

    rtf = result.sim_time / max(result.wall_time, 1e-9)
    command = time.perf_counter() - _STARTED
    out.print(
        f"[bold]{escape(result.scenario)}[/] seed {result.seed}: [{style}]{result.outcome}[/] in "
        f"{escape(str(result.final_state))} after {result.sim_time:.2f} s simulated "
        f"({command:.2f} s for the command with its start-up: the episode {result.wall_time:.2f}"
        f" s wall, {rtf:.0f}x real time)"
    )
    table = Table(escape("t [s]"), "from", "to", "trigger", box=None, pad_edge=False)
    shown = result.transitions
    cut = len(shown) - 2 * _TABLE_ENDS
    if cut > 1:  # a retry loop can make thousands: the first and last ones tell the story
        shown = [*shown[:_TABLE_ENDS], None, *shown[-_TABLE_ENDS:]]
    for tr in shown:
        if tr is None:
            table.add_row("...", f"({cut} more transitions: --json lists them all)", "", "")
            continue
        trigger = tr["trigger"] + (f": {tr['detail']}" if tr.get("detail") else "")
        table.add_row(f"{tr['t']:.2f}", escape(tr["from"]), escape(tr["to"]), escape(trigger))
    out.print(table)
    r = result.reason
    if r and "guard" not in r:  # the time limit (or the wall-clock limit) cut the run short
        out.print(f"stopped by {r.get('kind')}: {r['message']}", markup=False, soft_wrap=True)
    elif r:
        out.print(
            f"[red]aborted by {escape(str(r['guard']))}[/]: {escape(str(r['message']))} "
            f"(value {r['value']}, limit {r['limit']})"
        )
    if result.success:
        marks = ", ".join(f"{k} {'ok' if v else 'FAILED'}" for k, v in result.success.items())
        out.print(f"success: {marks}", markup=False)
        for name, ok in result.success.items():
            if not ok:
                detail = result.success_detail.get(name, "")
                out.print(f"[yellow]{escape(name)} failed[/]: {escape(detail)}", soft_wrap=True)
    metrics = ", ".join(f"{k} {v}" for k, v in result.metrics.items())
    out.print(f"metrics: {metrics}", markup=False, soft_wrap=True)
    if result.retries:
        out.print(f"retries: {result.retries}", markup=False)


@app.command()
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

    from .batch.fault_matrix import RowResult, run_matrix

    _note_entry(scenario)
    _use_skills(skills)

    def progress(row: RowResult) -> None:
        if not as_json:
            err.print(f"  {row.fault}: {row.outcome}", markup=False)

    try:
        rows = run_matrix(scenario, seed, set_ or [], on_row=progress)
    except ConfigError as exc:
        _fail_config(exc)
        return
    if as_json:
        _json_line([r.to_dict() for r in rows])
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
    from .batch.fault_matrix import DETECTED_BY, fault_kind

    kinds = list(dict.fromkeys(fault_kind(r.fault) for r in rows if r.blind))
    if kinds:
        which = "; ".join(f"{k} (needs {' or '.join(DETECTED_BY[k])})" for k in kinds)
        err.print(
            f"warning: no guard of this scenario can detect these fault kinds: {which}; add "
            "the guard to its `guards:` to have them caught",
            markup=False,
            soft_wrap=True,
        )


@app.command()
def validate(
    paths: Annotated[
        list[str],
        typer.Argument(help="Machine or scenario files, folders of them, or bundled names."),
    ],
    allow_path: AllowPathOption = None,
    skills: SkillPaths = None,
) -> None:
    """Check machines and scenarios without simulating: all errors at once, exit 2 if any.
    Runs no code a file names: a scenario's `skills:` are not imported (pass --skills DIR)."""
    from .language.validate_paths import validate_paths

    _use_skills(skills)
    try:
        problems, checked = validate_paths(paths, _allowed(allow_path))
    except ConfigError as exc:  # e.g. a bad $ORCHESTRATOR_LIMITS
        problems, checked = exc.diagnostics, []
    if problems:
        _fail_config(ConfigError(problems))
    for kind, name in checked:
        _plain(f"ok  {kind:8} {name}")


@app.command()
def graph(
    machine: Annotated[
        str, typer.Argument(help="Machine file or bundled name, or a scenario (its machine).")
    ],
    fmt: Annotated[
        str, typer.Option("--format", help="mermaid (no system package needed) or dot (Graphviz).")
    ] = "mermaid",
    allow_path: AllowPathOption = None,
    skills: SkillPaths = None,
) -> None:
    """Draw a machine: states, outcome-labelled transitions, nested clusters, the abort path."""
    from .language.entries import file_kind, unknown_entry
    from .language.graph import to_dot, to_mermaid
    from .language.load import load_machine, load_scenario

    if fmt not in ("mermaid", "dot"):
        err.print(f"--format: unknown format {fmt[:80]!r} (valid: mermaid, dot)", markup=False)
        raise typer.Exit(EXIT_INVALID)
    _use_skills(skills)
    _note_entry(machine)
    try:
        kind = file_kind(machine)
        if kind is None:
            raise ConfigError([unknown_entry(machine, "<machine>")])
        if kind[0] == "scenario" and not Path(machine).is_file():  # a bundled scenario
            node = load_scenario(machine, import_skills=False).machine
        elif kind[0] == "scenario":
            loaded = load_scenario(machine, allow_paths=_allowed(allow_path), import_skills=False)
            err.print(
                f"{machine} is a scenario: drawing its machine {loaded.scenario.machine!r}",
                markup=False,
                soft_wrap=True,
            )
            node = loaded.machine
        else:
            node = load_machine(machine, allow_paths=_allowed(allow_path))
    except ConfigError as exc:
        _fail_config(exc, "nothing was drawn")
        return
    sys.stdout.write(to_mermaid(node) if fmt == "mermaid" else to_dot(node))


@app.command()
def schema(
    kind: Annotated[str, typer.Argument(help="machine or scenario")],
    skills: SkillPaths = None,
) -> None:
    """Print the JSON Schema (draft 7) of machine or scenario files, for yaml-language-server.

    It knows every installed plugin skill and `--skills` folder: save it
    (`orchestrator schema machine --skills my_skills > machine.schema.json`) and point the
    editor at it with `# yaml-language-server: $schema=machine.schema.json`."""
    from .language.schema_gen import schema_text

    if kind not in ("machine", "scenario"):
        err.print(f"unknown schema {kind[:80]!r} (valid: machine, scenario)", markup=False)
        raise typer.Exit(EXIT_INVALID)
    _use_skills(skills)
    sys.stdout.write(schema_text(kind))


LISTS = ("scenarios", "machines", "skills", "checks", "guards", "robots")


@app.command(name="list")
def list_(
    what: Annotated[
        str | None,
        typer.Argument(help="scenarios, machines, skills, checks, guards or robots (all)."),
    ] = None,
    skills: SkillPaths = None,
) -> None:
    """Bundled scenarios and machines, available skills and success checks (with plugins),
    guards and robots."""
    from rich.table import Table

    from .guards import GUARDS
    from .language.bundled import bundled_names
    from .language.diagnostics import did_you_mean
    from .robots import ROBOTS
    from .skills import all_skills
    from .skills.plugins import skill_origin
    from .success import CHECKS, check_origin

    if what is not None and what not in LISTS:
        hint = did_you_mean(what, LISTS)
        err.print(f"unknown list {what!r}{hint} (valid: {', '.join(LISTS)})", markup=False)
        raise typer.Exit(EXIT_INVALID)
    _use_skills(skills)
    show = LISTS if what is None else (what,)
    if "scenarios" in show:
        out.print("[bold]scenarios[/]: " + escape(", ".join(bundled_names("scenarios"))))
    if "machines" in show:
        out.print("[bold]machines[/]:  " + escape(", ".join(bundled_names("machines"))))
    if "skills" in show:
        table = Table("skill", "outcomes", "description", box=None, pad_edge=False)
        skills_by_name = all_skills()
        for name in sorted(skills_by_name):
            cls = skills_by_name[name]
            origin = skill_origin(cls)
            doc = _first_sentence(cls) + ("" if origin == "bundled" else f" ({origin})")
            table.add_row(escape(name), escape(", ".join(cls.outcomes)), escape(doc))
        out.print(table)
        out.print("`orchestrator show skill NAME`: parameters with types, units and defaults.")
    if "checks" in show:
        table = Table("success check", "description", box=None, pad_edge=False)
        for kind in sorted(CHECKS):
            cls = CHECKS[kind]
            origin = check_origin(cls)
            doc = _first_sentence(cls) + ("" if origin == "bundled" else f" ({origin})")
            table.add_row(escape(kind), escape(doc))
        out.print(table)
        out.print(
            "`orchestrator show check KIND`: its parameters; a scenario's `success:` uses it."
        )
    if "guards" in show:
        out.print("[bold]guards[/]:    " + escape(", ".join(sorted(GUARDS))))
    if "robots" in show:
        out.print("[bold]robots[/]:    " + escape(", ".join(sorted(ROBOTS))))
    if what is None:
        from .perception.backends import backend_status

        out.print("[bold]camera renderer[/]: " + escape(backend_status().describe()))


def _first_sentence(cls: type) -> str:
    text = " ".join((cls.__doc__ or "").split())
    return text.split(". ")[0].rstrip(".") + "." if text else ""


SHOWS = ("skill", "check", "guard", "scenario", "machine")


@app.command()
def show(
    kind: Annotated[str, typer.Argument(help="skill, check, guard, scenario or machine")],
    name: Annotated[str, typer.Argument(help="Its name (a scenario or machine: or a file).")],
    skills: SkillPaths = None,
) -> None:
    """Describe one skill, success check or guard (parameters: type, unit, default, range;
    outcomes; blackboard writes), one scenario (scene, the blackboard values it uses and
    --set takes, success checks) or one machine (its graph in Mermaid)."""
    from .guards import GUARDS
    from .language import reference
    from .language.diagnostics import did_you_mean
    from .skills import all_skills
    from .success import CHECKS

    if kind not in SHOWS:
        hint = did_you_mean(kind, SHOWS)
        err.print(f"unknown kind {kind!r}{hint} (valid: {', '.join(SHOWS)})", markup=False)
        raise typer.Exit(EXIT_INVALID)
    _use_skills(skills)
    if kind in ("skill", "check", "guard"):
        table: dict = {"skill": all_skills(), "check": CHECKS, "guard": GUARDS}[kind]
        if name not in table:
            hint = did_you_mean(name, table)
            valid = ", ".join(sorted(table))
            err.print(f"unknown {kind} {name!r}{hint} (valid: {valid})", markup=False)
            raise typer.Exit(EXIT_INVALID)
        page = {
            "skill": reference.skill_markdown,
            "check": reference.check_markdown,
            "guard": reference.guard_markdown,
        }[kind](table[name], level=1)
    elif kind == "scenario":
        from .language.load import load_scenario

        try:
            page = reference.scenario_summary(load_scenario(name, import_skills=False))
        except ConfigError as exc:
            _fail_config(exc, "nothing to show")
            return
    else:
        graph(name, "mermaid", None)
        return
    _print_markdown(page)


def _print_markdown(page: str) -> None:
    if out.is_terminal:
        from rich.markdown import Markdown

        out.print(Markdown(page))
    else:
        sys.stdout.write(page)


@app.command()
def batch(
    scenario: Annotated[str, typer.Argument(help="Scenario file or bundled name.")],
    episodes: Annotated[int, typer.Option("-n", "--episodes", min=1, help="Number of episodes.")],
    seed_base: Annotated[
        int, typer.Option(min=0, max=MAX_SEED, help="Episode i runs seed SEED_BASE + i (>= 0).")
    ] = 0,
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

    from .batch import BatchConfig, BatchError, run_batch
    from .batch.config import DEFAULT_MAX_WALL_S
    from .batch.progress import NullProgress, RichProgress
    from .batch.report import print_summary

    _check_wall(max_wall_s)
    _note_entry(scenario)
    _use_skills(skills)
    if seed_base + episodes - 1 > MAX_SEED:
        _fail(f"--seed-base {seed_base} + -n {episodes} runs past the largest seed {MAX_SEED}")
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
        allow_paths=tuple(str(p) for p in _allowed(allow_path)),
        snapshot_on_failure=snapshot_on_failure,
        skill_paths=tuple(str(p.resolve()) for p in skills or ()),
    )
    show = sys.stdout.isatty() and not as_json
    progress = RichProgress(_rich(out), label=Path(scenario).stem) if show else NullProgress()

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
        _json_line(summary.to_json_dict())
    else:
        print_summary(summary, _rich(out))
    if strict:  # docs/invariants.md
        from .batch.store import ResultsStore
        from .engine.invariants import violated_names

        names = violated_names(list(ResultsStore(out_dir).load().values()))
        for name, n in names.items():
            err.print(f"invariant {name} violated in {n} episodes", markup=False)
        if names:
            raise typer.Exit(1)
    raise typer.Exit(1 if summary.errors else 0)


from .explore.command import explore_command  # noqa: E402  (docs/explore.md)

app.command(name="explore")(explore_command)

# -- snapshots ----------------------------------------------------------------------------------

snapshot_app = typer.Typer(
    help="Read a snapshot's header, or sign one you trust (docs/time-travel.md).",
    no_args_is_help=True,
)
app.add_typer(snapshot_app, name="snapshot")


def _snapshot_header(path: Path) -> dict:
    """A snapshot file's header (bounded reads; exit 2 if it is not one)."""
    from .engine.snapshot import SnapshotError
    from .engine.snapshot.run_snapshot import check_any_header
    from .engine.snapshot.snapfile import read_header

    try:
        return check_any_header(path, read_header(path))
    except SnapshotError as exc:
        _fail(str(exc))
        raise  # unreachable: _fail exits


@snapshot_app.command("show")
def snapshot_show(
    path: Annotated[Path, typer.Argument(help="The snapshot file.")],
    as_json: Annotated[bool, typer.Option("--json", help="Print the header as JSON.")] = False,
) -> None:
    """What a snapshot is of: scenario, seed, time, state, break point, versions (a snapshot is
    data: safe on any file, read within a size limit). Says whether this user's key signed it."""
    from .engine.snapshot import SnapshotError, read_snapshot

    header = _snapshot_header(path)
    try:
        read_snapshot(path)
        signed = "yes: `run --from` loads it"
    except SnapshotError as exc:
        signed = f"no ({exc})"
    if as_json:
        _json_line({**header, "signed_by_you": signed.startswith("yes")})
        return
    stop = header["break"] if isinstance(header.get("break"), dict) else {}
    versions = header["versions"] if isinstance(header.get("versions"), dict) else {}
    for key, value in (
        ("scenario", f"{header.get('scenario')} ({header.get('scenario_file')})"),
        ("seed", header.get("seed")),
        ("at", f"t={header.get('t')} s, control tick {header.get('tick')}"),
        ("state", header.get("state")),
        ("stopped for", f"{stop.get('reason')} ({stop.get('option')})"),
        ("versions", ", ".join(f"{k} {v}" for k, v in versions.items())),
        ("signed by you", signed),
    ):
        out.print(f"{key + ':':14} {value}", markup=False, soft_wrap=True)


@snapshot_app.command("trust")
def snapshot_trust(
    path: Annotated[Path, typer.Argument(help="The snapshot file.")],
) -> None:
    """Sign a snapshot with your key, so that `run --from` loads it: for a snapshot from someone
    you trust to have taken it (a snapshot is data and runs no code; the signature says who
    wrote it and that it is unchanged)."""
    from .engine.snapshot import SnapshotError, trust

    _snapshot_header(path)
    try:
        trust(path)
    except (SnapshotError, OSError) as exc:
        _fail(f"{path}: {exc}")
    err.print(f"{path} is signed with your key now", markup=False)


# -- live sessions ------------------------------------------------------------------------------

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


def _live_error(exc: Exception, code: int = EXIT_INVALID) -> None:
    err.print(f"error: {exc}", markup=False, soft_wrap=True)
    raise typer.Exit(code)


def _credentials(
    user: str | None, password: str | None, credentials: Path | None, tls_ca: Path | None,
    tls_cert: Path | None = None, tls_key: Path | None = None,
):  # fmt: skip
    """The client's credentials from options, environment and file, or exit 2 saying why."""
    from .live.access import AccessError, Credentials

    try:
        return Credentials.resolve(user, password, credentials, tls_ca, tls_cert, tls_key)
    except AccessError as exc:
        _live_error(exc)


@app.command()
def serve(
    scenario: Annotated[str, typer.Argument(help="Scenario file or bundled name: the world.")],
    session: Annotated[str, typer.Option("--session", help="The session's name.")],
    seed: Annotated[int, typer.Option(help="The world's seed.")] = 0,
    speed: Annotated[
        float, typer.Option(min=0.0, help="Simulated s per wall s while a task runs (0: max).")
    ] = 1.0,
    watchdog: Annotated[
        float,
        typer.Option(
            min=0.0,
            help="Stop a task and go to ERROR when its owner sends no "
            "heartbeat for S s (0: no watchdog).",
        ),
    ] = 1.0,
    queue: Annotated[
        int,
        typer.Option(
            "--queue",
            min=0,
            help="Tasks that may wait behind the running one "
            "(0: a run while busy is refused, naming the running task).",
        ),
    ] = 0,
    snapshots: Annotated[
        Path,
        typer.Option(
            "--snapshots",
            help="Folder where `send NAME snapshot` writes and `send NAME restore` reads "
            "(made when the first snapshot is written).",
        ),
    ] = Path("snapshots"),
    snapshot_count: Annotated[
        int,
        typer.Option(
            "--snapshot-count", min=1, help="Snapshots the session may write in all (the cap)."
        ),
    ] = 100,
    snapshot_mb: Annotated[
        float,
        typer.Option(
            "--snapshot-mb", min=0.001, help="Megabytes of snapshots the session may write in all."
        ),
    ] = 2048.0,
    listen: Annotated[
        list[str] | None,
        typer.Option(
            "--listen",
            help="Zenoh endpoint to listen on (default tcp/127.0.0.1:7447)."
            " Another than loopback needs mutual TLS: tls/HOST:PORT with --tls-cert, "
            "--tls-key and --tls-ca.",
        ),
    ] = None,
    connect: Endpoints = None,
    users: Annotated[
        Path | None,
        typer.Option(
            "--users",
            envvar="ORCHESTRATOR_USERS",
            help="Authenticate clients: a file of user:password lines (Zenoh's "
            "dictionary format, chmod 600); its users may command, except --viewer.",
        ),
    ] = None,
    viewer: Annotated[
        list[str] | None,
        typer.Option(
            "--viewer", help="A user of --users who may only watch and e-stop. Repeatable."
        ),
    ] = None,
    tls_cert: Annotated[
        Path | None,
        typer.Option(
            "--tls-cert",
            envvar="ORCHESTRATOR_TLS_CERT",
            help="The session's TLS certificate (PEM) for tls/ endpoints.",
        ),
    ] = None,
    tls_key: Annotated[
        Path | None,
        typer.Option(
            "--tls-key", envvar="ORCHESTRATOR_TLS_KEY", help="Its private key (PEM, chmod 600)."
        ),
    ] = None,
    user: UserOption = None,
    password: PasswordOption = None,
    credentials: CredentialsOption = None,
    tls_ca: Annotated[
        Path | None,
        typer.Option(
            "--tls-ca",
            envvar="ORCHESTRATOR_TLS_CA",
            help="CA certificate (PEM) whose certificates the session admits: with "
            "--tls-cert and --tls-key, a client must present one (mutual TLS).",
        ),
    ] = None,
    spawn: Annotated[
        bool, typer.Option(help="Stream every task live to a spawned Rerun viewer.")
    ] = False,
    rrd: Annotated[
        Path | None,
        typer.Option(help="Save a Rerun recording of every task into this folder."),
    ] = None,
    allow_path: AllowPathOption = None,
) -> None:
    """Keep a world running and take commands over Zenoh (see docs/live.md). --user,
    --password and --credentials are what the session presents to --connect (with its
    --tls-cert, under mutual TLS)."""
    from .live.access import AccessError, ServerAccess
    from .live.protocol import DEFAULT_ENDPOINT
    from .live.server import serve as serve_session
    from .live.session import Session

    if not session or "/" in session or "*" in session:
        _live_error(ValueError(f"--session {session!r}: a name without '/' or '*' (e.g. cell1)"))
    endpoints = list(listen or [DEFAULT_ENDPOINT])
    access = ServerAccess(users, tuple(viewer or ()), tls_cert, tls_key, tls_ca)
    try:  # before building anything: an exposed session is refused at once
        access.check(endpoints, list(connect or []))
    except AccessError as exc:
        _live_error(exc)
    own = _credentials(user, password, credentials, tls_ca)
    recorder = None
    if spawn or rrd is not None:
        from .recording import RerunRecorder

        def recorder(task):
            stem = Path(task.machine_ref).stem
            path = None if rrd is None else rrd / f"task-{task.id}-{stem}.rrd"
            return RerunRecorder(path=path, spawn=spawn)

    try:
        live = Session(
            scenario,
            session,
            seed=seed,
            speed=speed,
            watchdog_s=watchdog or None,
            recorder=recorder,
            allow_paths=_allowed(allow_path),
            queue_limit=queue,
            snapshot_dir=snapshots,
            snapshot_count=snapshot_count,
            snapshot_bytes=round(snapshot_mb * 2**20),
        )
    except ConfigError as exc:
        _fail_config(exc)
        return

    admits = [f"mutual TLS, clients' CA {tls_ca}"] if access.mutual else []
    admits += [f"users: {users}"] if users else []

    def ready() -> None:
        err.print(f"session {session!r} ready on {', '.join(endpoints)} (epoch {live.epoch}, "
                  f"watchdog {f'{watchdog} s' if watchdog else 'off'}, "
                  f"{', '.join(admits) or 'no authentication'})",
                  markup=False)  # fmt: skip

    try:
        serve_session(live, endpoints, connect, ready, access=access, credentials=own)
    except AccessError as exc:
        _live_error(exc)
    except Exception as exc:  # Zenoh cannot open its endpoints: say which, no traceback
        if "zenoh" not in type(exc).__module__.lower() and not isinstance(exc, OSError):
            raise
        _live_error(RuntimeError(f"cannot open Zenoh on {', '.join(endpoints)}: {exc}"))


@app.command()
def send(
    session: Annotated[str, typer.Argument(help="The session's name.")],
    command: Annotated[
        str,
        typer.Argument(
            help="run, stop, estop, reset, pause, resume, status, shutdown, recover, snapshot, "
            "restore or reload."
        ),
    ],
    machine: Annotated[
        str | None,
        typer.Argument(help="For run: machine file or bundled name; for reload: the file."),
    ] = None,
    set_: Annotated[
        list[str] | None, typer.Option("--set", help="For run: a blackboard value KEY=VALUE.")
    ] = None,
    wait: Annotated[bool, typer.Option(help="For run: wait for the task's end.")] = False,
    preempt: Annotated[
        bool, typer.Option(help="For run: stop the running task under control, then run this.")
    ] = False,
    as_json: Annotated[bool, typer.Option("--json", help="Print JSON.")] = False,
    connect: Endpoints = None,
    user: UserOption = None,
    password: PasswordOption = None,
    credentials: CredentialsOption = None,
    tls_ca: TlsCaOption = None,
    tls_cert: ClientCertOption = None,
    tls_key: ClientKeyOption = None,
    name: Annotated[
        str | None,
        typer.Option(
            "--name",
            help="For snapshot: the file's name (default: session and tick); for "
            "restore: the snapshot to restore (in the session's --snapshots folder).",
        ),
    ] = None,
) -> None:
    """Send a command. Exit 2 if rejected; with --wait, the task's exit code (0 succeeded,
    1 failed, 3 aborted), or 5 if the session is lost while waiting (killed, shut down,
    network gone: noticed within about a second)."""
    from .live.client import EXIT_SESSION_LOST, Client, LiveError, SessionLost
    from .live.protocol import COMMANDS

    if command not in COMMANDS:
        _live_error(ValueError(f"unknown command {command!r} (valid: {', '.join(COMMANDS)})"))
    if command == "recover" and (machine or set_):
        _live_error(ValueError("recover: takes no MACHINE and no --set (it runs `recover`)"))
    elif command == "reload" and (not machine or set_ or wait or preempt):
        _live_error(ValueError("reload: give the MACHINE file (and no --set, --wait, --preempt)"))
    elif command not in ("run", "recover", "reload") and (machine or set_ or wait or preempt):
        only = "takes no MACHINE, --set, --wait or --preempt (only run does)"
        _live_error(ValueError(f"{command}: {only}"))
    if name is not None and command not in ("snapshot", "restore"):
        _live_error(ValueError(f"{command}: takes no --name (only snapshot and restore do)"))
    creds = _credentials(user, password, credentials, tls_ca, tls_cert, tls_key)
    watchdog_s = None
    try:
        with Client(session, connect, name="orchestrator send", credentials=creds) as client:
            if command in ("run", "recover"):  # recover: the bundled recovery machine
                target, values = (machine, set_ or []) if command == "run" else ("recover", [])
                reply, result = client.run(target, values, wait=wait, preempt=preempt)
                if reply.accepted and not wait:
                    watchdog_s = client.status().get("watchdog_s")
            elif command == "estop":
                reply, result = client.estop(), None
            else:
                reply, result = client.command(command, machine, snapshot=name), None
    except SessionLost as exc:
        _live_error(exc, EXIT_SESSION_LOST)
        return
    except LiveError as exc:
        _live_error(exc)
        return
    if not reply.accepted:
        if as_json:
            _json_line(reply.model_dump(mode="json"))
        err.print(f"rejected: {reply.reason}", markup=False, soft_wrap=True)
        raise typer.Exit(EXIT_INVALID)
    if result is not None:
        if as_json:
            _json_line(result)
        else:
            out.print(f"task {result['task']} {result['machine']}: {result['outcome']} "
                      f"in {result['final_state']} after {result['sim_time']:.2f} s",
                      markup=False)  # fmt: skip
        raise typer.Exit(result["exit_code"])
    if wait:  # the session refused to start the task after accepting it
        _live_error(RuntimeError(f"task {reply.task} did not run (see the session's events)"))
    if as_json:
        _json_line(reply.model_dump(mode="json"))
    elif reply.status is not None:
        out.print_json(_strict_json(reply.status))
    elif reply.snapshot is not None:
        out.print(f"accepted: {command} {reply.snapshot}", markup=False)
    else:
        out.print(f"accepted{f': task {reply.task}' if reply.task else ''}", markup=False)
        if reply.task and watchdog_s:
            err.print(f"note: this client, the task's owner, stops sending heartbeats now: "
                      f"the session's watchdog stops the task after {watchdog_s} s (use "
                      "--wait to supervise it)", markup=False)  # fmt: skip


@app.command()
def watch(
    session: Annotated[str, typer.Argument(help="The session's name.")],
    connect: Endpoints = None,
    duration: Annotated[
        float | None, typer.Option("--for", help="Stop after S seconds (default: Ctrl-C).")
    ] = None,
    user: UserOption = None,
    password: PasswordOption = None,
    credentials: CredentialsOption = None,
    tls_ca: TlsCaOption = None,
    tls_cert: ClientCertOption = None,
    tls_key: ClientKeyOption = None,
) -> None:
    """A live table of a session's status; warns when its heartbeats stop."""
    from .live.watch import watch as watch_session

    creds = _credentials(user, password, credentials, tls_ca, tls_cert, tls_key)
    raise typer.Exit(watch_session(session, connect, duration, _rich(out), creds))


@app.command()
def ask(
    session: Annotated[str, typer.Argument(help="The session's name.")],
    instruction: Annotated[str, typer.Argument(help='What to do, e.g. "put the cube on pad".')],
    wait: Annotated[bool, typer.Option(help="Wait for the task's end.")] = False,
    as_json: Annotated[bool, typer.Option("--json", help="Print JSON.")] = False,
    connect: Endpoints = None,
    user: UserOption = None,
    password: PasswordOption = None,
    credentials: CredentialsOption = None,
    tls_ca: TlsCaOption = None,
    tls_cert: ClientCertOption = None,
    tls_key: ClientKeyOption = None,
) -> None:
    """Ask a planner (an OpenAI-compatible endpoint) for a command; it goes through the
    same guardrails as any other. Set ORCHESTRATOR_PLANNER_URL (and _MODEL, _KEY). With
    --wait, exit 5 if the session is lost while waiting."""
    from .live.client import EXIT_SESSION_LOST, Client, LiveError, SessionLost
    from .live.planner import PlannerError, ask_planner, planner_url

    creds = _credentials(user, password, credentials, tls_ca, tls_cert, tls_key)
    try:
        planner_url()  # before connecting: say at once that there is none
        with Client(session, connect, name="orchestrator ask", credentials=creds) as client:
            proposal, reply, result = ask_planner(client, instruction, wait=wait)
    except SessionLost as exc:
        _live_error(exc, EXIT_SESSION_LOST)
        return
    except (PlannerError, LiveError) as exc:
        _live_error(exc)
        return
    if as_json:
        _json_line({"proposal": proposal, "reply": reply.model_dump(mode="json"), "result": result})
    else:
        out.print(f"planner proposes: {_strict_json(proposal)}", markup=False)
    if not reply.accepted:
        err.print(f"rejected: {reply.reason}", markup=False, soft_wrap=True)
        raise typer.Exit(EXIT_INVALID)
    if result is not None:
        if not as_json:
            out.print(f"task {result['task']}: {result['outcome']}", markup=False)
        raise typer.Exit(result["exit_code"])
    if not as_json:
        out.print(f"accepted: task {reply.task}", markup=False)


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


if __name__ == "__main__":
    main()
