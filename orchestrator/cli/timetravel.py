"""Time travel: `run --break ...` (run to a break point, write its snapshot), `run --from`
(resume one), and the `snapshot` commands (read a header, sign a snapshot you trust)."""

# No `from __future__ import annotations`: typer reads the parameter annotations of every
# command each time the CLI starts; as strings, each would be compiled and evaluated again
# (cli/__init__.py).
from pathlib import Path
from typing import Annotated

import typer

from ..exceptions import ConfigError
from .console import err, json_line, out
from .errors import EXIT_BREAK, EXIT_ERROR, fail, fail_config
from .results import finish


def checked_break_points(machine, states: list[str], guards: list[str], at_t: float | None):
    """The break points of the options, checked against `machine` (exit 2 otherwise)."""
    from ..engine.snapshot.breaks import break_points

    try:
        return break_points(machine, states, guards, at_t)
    except ConfigError as exc:
        fail_config(exc)
        raise  # unreachable: fail_config exits


def run_to_break(make_run, points, out: Path | None, as_json: bool, debug: bool) -> None:
    """Run to the first break point and write its snapshot (exit 6), or to the end if none is
    reached (its exit code)."""
    from ..engine.snapshot import Broken, SnapshotError, break_run

    try:
        broken = break_run(make_run, points, out)
    except SnapshotError as exc:
        fail(str(exc))
        return
    if not isinstance(broken, Broken):  # the run ended first: its result
        result = broken
        options = ", ".join(p.option for p in points)
        err.print(f"no break point was reached ({options}): the run ended", markup=False)
        finish(result, as_json, debug, None)
        return
    if as_json:
        json_line(broken.to_json_dict())
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


def run_from(
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
    from ..engine.prepare import check_resumed_goals
    from ..engine.runner import WallTimeExceeded, drive
    from ..engine.snapshot import SnapshotError, open_run

    if faults or events:
        fail(
            "--fault and --event shape a run from its start: a resumed run has its snapshot's "
            "(run the scenario again with them, and --break where you want)"
        )
    try:
        opened = open_run(path, scenario, seed, sets)
    except SnapshotError as exc:
        fail(str(exc))
        return
    except ConfigError as exc:
        fail_config(exc, "nothing was resumed")
        return
    run = opened.run
    try:
        check_resumed_goals(run, sets)
    except ConfigError as exc:
        fail_config(exc, "nothing was resumed")
    states, guards, at_t = breaks
    if states or guards or at_t is not None:
        points = checked_break_points(run.loaded.machine, states, guards, at_t)
        first = [run]

        def again():  # the snapshot read back once more for the second pass
            if first:
                return first.pop()
            return open_run(path, scenario, seed, sets).run

        run_to_break(again, points, snapshot, as_json, debug)
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
        from ..recording import RerunRecorder

        observers.append(RerunRecorder(path=rrd, spawn=spawn, connect=connect))
    try:
        result = drive(run, observers, max_wall_s)
    except ConfigError as exc:
        fail_config(exc)
        return
    except WallTimeExceeded as exc:
        err.print(f"error: {exc}", markup=False, soft_wrap=True)
        raise typer.Exit(EXIT_ERROR) from None
    assert result is not None
    finish(result, as_json, debug, rrd)


snapshot_app = typer.Typer(
    help="Read a snapshot's header, or sign one you trust (docs/time-travel.md).",
    no_args_is_help=True,
)


def _snapshot_header(path: Path) -> dict:
    """A snapshot file's header (bounded reads; exit 2 if it is not one)."""
    from ..engine.snapshot import SnapshotError
    from ..engine.snapshot.run_snapshot import check_any_header
    from ..engine.snapshot.snapfile import read_header

    try:
        return check_any_header(path, read_header(path))
    except SnapshotError as exc:
        fail(str(exc))
        raise  # unreachable: fail exits


@snapshot_app.command("show")
def snapshot_show(
    path: Annotated[Path, typer.Argument(help="The snapshot file.")],
    as_json: Annotated[bool, typer.Option("--json", help="Print the header as JSON.")] = False,
) -> None:
    """What a snapshot is of: scenario, seed, time, state, break point, versions (a snapshot is
    data: safe on any file, read within a size limit). Says whether this user's key signed it."""
    from ..engine.snapshot import SnapshotError, read_snapshot

    header = _snapshot_header(path)
    try:
        read_snapshot(path)
        signed = "yes: `run --from` loads it"
    except SnapshotError as exc:
        signed = f"no ({exc})"
    if as_json:
        json_line({**header, "signed_by_you": signed.startswith("yes")})
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
    from ..engine.snapshot import SnapshotError, trust

    _snapshot_header(path)
    try:
        trust(path)
    except (SnapshotError, OSError) as exc:
        fail(f"{path}: {exc}")
    err.print(f"{path} is signed with your key now", markup=False)
