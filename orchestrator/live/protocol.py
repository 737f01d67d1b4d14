"""The command protocol of a live session: commands, replies, status and the Zenoh keys.

Every message is one JSON object. A client sends a `Command` as the payload of a query on
`orchestrator/<session>/command`; the session answers with a `Reply` (accepted or rejected,
with the reason). The session publishes its `status` at 10 Hz, its own `heartbeat`, and an
`events` stream (task started, task ended with its result, e-stop, watchdog); clients put
their heartbeats on `clients/heartbeat`.
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

COMMANDS = ("run", "stop", "estop", "reset", "pause", "resume", "status", "shutdown", "recover")
"""Every command a session takes."""
PRIORITY = {"estop": 0, "shutdown": 1, "stop": 1, "pause": 2, "resume": 2, "reset": 2, "run": 3,
            "recover": 3}  # fmt: skip
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
    """

    model_config = ConfigDict(extra="forbid")

    op: Literal["run", "stop", "estop", "reset", "pause", "resume", "status", "shutdown", "recover"]
    machine: str | None = Field(default=None, description="For `run`: machine path or name.")
    set: list[str] = Field(default_factory=list, description="For `run`: KEY=VALUE texts.")
    client: str = Field(default="", description="Who sends the command.")


class Reply(BaseModel):
    """The session's answer to a command."""

    accepted: bool
    reason: str = ""
    task: int | None = Field(default=None, description="The task id of an accepted `run`.")
    status: dict[str, Any] | None = Field(default=None, description="For `status`.")


def key(session: str, leaf: str) -> str:
    """The Zenoh key expression `orchestrator/<session>/<leaf>`."""
    return f"orchestrator/{session}/{leaf}"


def config_for(listen: list[str] | None = None, connect: list[str] | None = None) -> Any:
    """A Zenoh configuration: multicast scouting off, explicit endpoints only.

    Args:
        listen: Endpoints to listen on (the session), e.g. `tcp/127.0.0.1:7447`.
        connect: Endpoints to connect to (a client).
    """
    import json

    import zenoh

    conf = zenoh.Config()
    conf.insert_json5("scouting/multicast/enabled", "false")
    conf.insert_json5("scouting/gossip/enabled", "false")
    conf.insert_json5("listen/endpoints", json.dumps(list(listen or [])))
    conf.insert_json5("connect/endpoints", json.dumps(list(connect or [])))
    return conf
