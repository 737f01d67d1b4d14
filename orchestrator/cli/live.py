"""Live sessions: `serve` (keep a world running, take commands over Zenoh), and its clients
`send`, `watch` and `ask`."""

# No `from __future__ import annotations`: typer reads the parameter annotations of every
# command each time the CLI starts; as strings, each would be compiled and evaluated again
# (cli/__init__.py).
from pathlib import Path
from typing import Annotated

import typer

from ..exceptions import ConfigError
from .console import err, json_line, out, rich_console, strict_json
from .errors import EXIT_INVALID, fail_config, live_error
from .options import (
    AllowPathOption,
    ClientCertOption,
    ClientKeyOption,
    CredentialsOption,
    Endpoints,
    PasswordOption,
    TlsCaOption,
    UserOption,
    allowed_dirs,
)


def _credentials(
    user: str | None, password: str | None, credentials: Path | None, tls_ca: Path | None,
    tls_cert: Path | None = None, tls_key: Path | None = None,
):  # fmt: skip
    """The client's credentials from options, environment and file, or exit 2 saying why."""
    from ..live.access import AccessError, Credentials

    try:
        return Credentials.resolve(user, password, credentials, tls_ca, tls_cert, tls_key)
    except AccessError as exc:
        live_error(exc)


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
    from ..live.access import AccessError, ServerAccess
    from ..live.protocol import DEFAULT_ENDPOINT
    from ..live.server import serve as serve_session
    from ..live.session import Session

    if not session or "/" in session or "*" in session:
        live_error(ValueError(f"--session {session!r}: a name without '/' or '*' (e.g. cell1)"))
    endpoints = list(listen or [DEFAULT_ENDPOINT])
    access = ServerAccess(users, tuple(viewer or ()), tls_cert, tls_key, tls_ca)
    try:  # before building anything: an exposed session is refused at once
        access.check(endpoints, list(connect or []))
    except AccessError as exc:
        live_error(exc)
    own = _credentials(user, password, credentials, tls_ca)
    recorder = None
    if spawn or rrd is not None:
        from ..recording import RerunRecorder

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
            allow_paths=allowed_dirs(allow_path),
            queue_limit=queue,
            snapshot_dir=snapshots,
            snapshot_count=snapshot_count,
            snapshot_bytes=round(snapshot_mb * 2**20),
        )
    except ConfigError as exc:
        fail_config(exc)
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
        live_error(exc)
    except Exception as exc:  # Zenoh cannot open its endpoints: say which, no traceback
        if "zenoh" not in type(exc).__module__.lower() and not isinstance(exc, OSError):
            raise
        live_error(RuntimeError(f"cannot open Zenoh on {', '.join(endpoints)}: {exc}"))


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
    from ..live.client import EXIT_SESSION_LOST, Client, LiveError, SessionLost
    from ..live.protocol import COMMANDS

    if command not in COMMANDS:
        live_error(ValueError(f"unknown command {command!r} (valid: {', '.join(COMMANDS)})"))
    if command == "recover" and (machine or set_):
        live_error(ValueError("recover: takes no MACHINE and no --set (it runs `recover`)"))
    elif command == "reload" and (not machine or set_ or wait or preempt):
        live_error(ValueError("reload: give the MACHINE file (and no --set, --wait, --preempt)"))
    elif command not in ("run", "recover", "reload") and (machine or set_ or wait or preempt):
        only = "takes no MACHINE, --set, --wait or --preempt (only run does)"
        live_error(ValueError(f"{command}: {only}"))
    if name is not None and command not in ("snapshot", "restore"):
        live_error(ValueError(f"{command}: takes no --name (only snapshot and restore do)"))
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
        live_error(exc, EXIT_SESSION_LOST)
        return
    except LiveError as exc:
        live_error(exc)
        return
    if not reply.accepted:
        if as_json:
            json_line(reply.model_dump(mode="json"))
        err.print(f"rejected: {reply.reason}", markup=False, soft_wrap=True)
        raise typer.Exit(EXIT_INVALID)
    if result is not None:
        if as_json:
            json_line(result)
        else:
            out.print(f"task {result['task']} {result['machine']}: {result['outcome']} "
                      f"in {result['final_state']} after {result['sim_time']:.2f} s",
                      markup=False)  # fmt: skip
        raise typer.Exit(result["exit_code"])
    if wait:  # the session refused to start the task after accepting it
        live_error(RuntimeError(f"task {reply.task} did not run (see the session's events)"))
    if as_json:
        json_line(reply.model_dump(mode="json"))
    elif reply.status is not None:
        out.print_json(strict_json(reply.status))
    elif reply.snapshot is not None:
        out.print(f"accepted: {command} {reply.snapshot}", markup=False)
    else:
        out.print(f"accepted{f': task {reply.task}' if reply.task else ''}", markup=False)
        if reply.task and watchdog_s:
            err.print(f"note: this client, the task's owner, stops sending heartbeats now: "
                      f"the session's watchdog stops the task after {watchdog_s} s (use "
                      "--wait to supervise it)", markup=False)  # fmt: skip


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
    from ..live.watch import watch as watch_session

    creds = _credentials(user, password, credentials, tls_ca, tls_cert, tls_key)
    raise typer.Exit(watch_session(session, connect, duration, rich_console(out), creds))


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
    from ..live.client import EXIT_SESSION_LOST, Client, LiveError, SessionLost
    from ..live.planner import PlannerError, ask_planner, planner_url

    creds = _credentials(user, password, credentials, tls_ca, tls_cert, tls_key)
    try:
        planner_url()  # before connecting: say at once that there is none
        with Client(session, connect, name="orchestrator ask", credentials=creds) as client:
            proposal, reply, result = ask_planner(client, instruction, wait=wait)
    except SessionLost as exc:
        live_error(exc, EXIT_SESSION_LOST)
        return
    except (PlannerError, LiveError) as exc:
        live_error(exc)
        return
    if as_json:
        json_line({"proposal": proposal, "reply": reply.model_dump(mode="json"), "result": result})
    else:
        out.print(f"planner proposes: {strict_json(proposal)}", markup=False)
    if not reply.accepted:
        err.print(f"rejected: {reply.reason}", markup=False, soft_wrap=True)
        raise typer.Exit(EXIT_INVALID)
    if result is not None:
        if not as_json:
            out.print(f"task {result['task']}: {result['outcome']}", markup=False)
        raise typer.Exit(result["exit_code"])
    if not as_json:
        out.print(f"accepted: task {reply.task}", markup=False)
