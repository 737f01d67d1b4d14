"""Live sessions: a world kept running that takes commands over Zenoh (see docs/live.md).

`Session` (the loop), `serve` (its Zenoh keys), `Client` (the Python client a program or a
planner uses; `SessionLost` when its session goes while it waits), `Credentials` and
`ServerAccess` (Zenoh authentication, access control and TLS), `check_goals` (the guardrail
every outside goal goes through) and `ask_planner` (an instruction in words -> a guarded
command).

Names are imported on first use: a client (`orchestrator send`) needs only Zenoh and the
protocol, not the physics and IK a session loads.
"""

from __future__ import annotations

import importlib
from typing import Any

__all__ = [
    "COMMANDS",
    "STATES",
    "AccessError",
    "Client",
    "Command",
    "Credentials",
    "GoalRejected",
    "LiveError",
    "PlannerCommand",
    "PlannerError",
    "Reply",
    "ServerAccess",
    "Session",
    "SessionLost",
    "ask_planner",
    "check_goals",
    "serve",
]

_WHERE = {
    "COMMANDS": "protocol", "STATES": "protocol", "Command": "protocol", "Reply": "protocol",
    "Client": "client", "LiveError": "client", "GoalRejected": "guardrail",
    "check_goals": "guardrail", "PlannerCommand": "planner", "PlannerError": "planner",
    "ask_planner": "planner", "serve": "server", "Session": "session",
    "SessionLost": "client", "AccessError": "access", "Credentials": "access",
    "ServerAccess": "access",
}  # fmt: skip


def __getattr__(name: str) -> Any:
    if name not in _WHERE:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(importlib.import_module(f".{_WHERE[name]}", __name__), name)
