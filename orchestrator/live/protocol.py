"""The command protocol of a live session: commands, replies, status and the Zenoh keys.

Every message is one JSON object. A client sends a `Command` as the payload of a query on
`orchestrator/<session>/command`; the session answers with a `Reply` (accepted or rejected,
with the reason). The e-stop has a key of its own, `estop` (a query or a put; any payload),
that no other command waits in front of. The session publishes its `status` at 10 Hz (and
answers queries on that key), its own `heartbeat`, an `events` stream (task started, task
ended with its result, e-stop, watchdog), and holds a liveliness token on `alive` while it
runs; clients put their heartbeats (their owner token) on `clients/heartbeat`.
"""

from __future__ import annotations

from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field

__all__ = [
    "COMMANDS",
    "PRIORITY",
    "STATES",
    "Command",
    "Reply",
    "config_for",
    "key",
]

COMMANDS = ("run", "stop", "estop", "reset", "pause", "resume", "status", "shutdown", "recover",
            "snapshot", "restore", "reload")  # fmt: skip
"""Every command a session takes."""
PRIORITY = {"estop": 0, "shutdown": 1, "stop": 1, "pause": 2, "resume": 2, "reset": 2, "run": 3,
            "recover": 3, "snapshot": 2, "restore": 3, "reload": 3}  # fmt: skip
"""Lower first: what arrives in the same control tick is applied in this order."""
STATES = ("IDLE", "MOVING", "GRASPING", "PAUSED", "BLOCKED", "ESTOPPED", "ERROR")
"""The robot's state as the session publishes it."""
DEFAULT_ENDPOINT = "tcp/127.0.0.1:7447"
"""Where `serve` listens and clients connect unless told otherwise (loopback only)."""


class Command(BaseModel):
    """One command to a session.

    Attributes:
        op: What to do (`COMMANDS`; `recover` runs the bundled `recover` machine).
        machine: For `run`: a machine file or a bundled name (`pick_place`, `home`, `reach`).
        set: For `run`: blackboard values `KEY=VALUE` (YAML values), checked by the guardrail.
        client: Who sends it (for the log).
        owner: For `run`: the sender's owner token; the watchdog counts only heartbeats that
            carry it (a bystander's do not keep the task alive).
        preempt: For `run`: stop the running task under control (and drop the queue), then
            run this one; without it a `run` while busy follows the session's queue policy.
        snapshot: For `snapshot`: a name for the file (default: session, epoch and tick); for
            `restore`: the snapshot's name. Plain names: the files stay in the session's
            snapshot folder (live/snapshots.py). `reload` names its file in `machine`.
    """

    model_config = ConfigDict(extra="forbid", strict=True)  # `"preempt": "yes"` is no bool

    op: Literal[
        "run", "stop", "estop", "reset", "pause", "resume", "status", "shutdown", "recover",
        "snapshot", "restore", "reload",
    ]  # fmt: skip
    machine: str | None = Field(default=None, description="For `run`: machine path or name.")
    set: list[str] = Field(default_factory=list, description="For `run`: KEY=VALUE texts.")
    client: str = Field(default="", max_length=128, description="Who sends the command.")
    owner: str = Field(default="", max_length=128, description="For `run`: owner token.")
    preempt: bool = Field(default=False, description="For `run`: replace the running task.")
    snapshot: str | None = Field(
        default=None, max_length=128, description="For `snapshot`/`restore`: the file's name."
    )


class Reply(BaseModel):
    """The session's answer to a command."""

    accepted: bool
    reason: str = ""
    task: str | None = Field(
        default=None,
        description="The task id of an accepted `run`: `<epoch>-<n>`, unique "
        "across restarts of the session.",
    )
    status: dict[str, Any] | None = Field(default=None, description="For `status`.")
    snapshot: str | None = Field(
        default=None, description="For `snapshot`: the file it writes; `restore`: it reads."
    )


def key(session: str, leaf: str) -> str:
    """The Zenoh key expression `orchestrator/<session>/<leaf>`."""
    return f"orchestrator/{session}/{leaf}"


def config_for(
    listen: list[str] | None = None, connect: list[str] | None = None, **access: Any
) -> Any:
    """A Zenoh configuration: scouting off, explicit endpoints, and the credentials, TLS and
    access control in `access` (`credentials`, `server`, `session`: see
    `access.zenoh_config`)."""
    from .access import zenoh_config

    return zenoh_config(listen, connect, **access)
