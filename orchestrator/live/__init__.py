"""Live sessions: a world kept running that takes commands over Zenoh (see docs/live.md).

`Session` (the loop), `serve` (its Zenoh keys), `Client` (the Python client a program or a
planner uses), `check_goals` (the guardrail every outside goal goes through) and
`ask_planner` (an instruction in words -> a guarded command).
"""

from __future__ import annotations

from .client import Client, LiveError
from .guardrail import GoalRejected, check_goals
from .planner import PlannerCommand, PlannerError, ask_planner
from .protocol import COMMANDS, STATES, Command, Reply
from .server import serve
from .session import Session

__all__ = [
    "COMMANDS",
    "STATES",
    "Client",
    "Command",
    "GoalRejected",
    "LiveError",
    "PlannerCommand",
    "PlannerError",
    "Reply",
    "Session",
    "ask_planner",
    "check_goals",
    "serve",
]
