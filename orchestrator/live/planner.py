"""The planner adapter: an instruction in words -> one guarded `run` command.

`orchestrator ask NAME "put the cube on the pad"` sends the instruction, the scene's object
and marker names, the machines a task may run (with their inputs: the only keys a planner may
set) and the JSON schema of `PlannerCommand` to an OpenAI-compatible chat-completions
endpoint. The reply must be that JSON object and nothing else, with finite numbers (`NaN` and
`Infinity` are refused); it is parsed into `PlannerCommand` (unknown fields are refused) and
submitted like any other command, so the session's checks apply in full: only the machine's
inputs may be set (never a guard, physics, scene or robot value), object names must be in the
scene, and every value that becomes a position goes through the guardrail (finite, in the
workspace, clear of no-go zones, reachable; a position hint near an object). Nothing the
planner says can move the robot without passing them, nor change a limit.

Configuration (environment variables): `ORCHESTRATOR_PLANNER_URL` (the API base, e.g.
`http://127.0.0.1:8080/v1`; `/chat/completions` is appended), `ORCHESTRATOR_PLANNER_MODEL`
(default `default`) and `ORCHESTRATOR_PLANNER_KEY` (sent as a bearer token, if set).
"""

from __future__ import annotations

import json
import math
import os
import re
from typing import Any

from pydantic import BaseModel, ConfigDict, Field, ValidationError

from ..exceptions import OrchestratorError
from .client import Client
from .protocol import Reply

__all__ = [
    "TASK_MACHINES",
    "PlannerCommand",
    "PlannerError",
    "ask_planner",
    "parse_reply",
    "planner_url",
    "system_prompt",
]

TASK_MACHINES = ("pick_place", "reach", "home")
"""The bundled machines a planner may propose."""
TIMEOUT_S = 60.0


class PlannerError(OrchestratorError):
    """No planner configured, the planner cannot be reached, or its reply is not a command."""


class PlannerCommand(BaseModel):
    """What the planner must answer: one task to run."""

    model_config = ConfigDict(extra="forbid")

    machine: str = Field(description="The machine to run: " + ", ".join(TASK_MACHINES) + ".")
    set: dict[str, Any] = Field(
        default_factory=dict,
        description='Blackboard values of that machine, e.g. {"object": "cube", '
        '"place_at": "pad"} or {"target": [0.5, 0.1, 0.4]} (metres, world frame).',
    )

    def as_sets(self) -> list[str]:
        """The `--set KEY=VALUE` texts of the command (values as JSON, a YAML subset)."""
        return [f"{k}={json.dumps(v)}" for k, v in self.set.items()]


def system_prompt(scene: dict[str, Any]) -> str:
    """The instructions: the scene's names, the machines and keys, the reply's schema."""
    from ..language.inputs import machine_inputs
    from ..language.load import load_machine

    lines = []
    for name in TASK_MACHINES:
        node = load_machine(name)
        keys = ", ".join(f"{k} ({t})" for k, t in machine_inputs(node).items()) or "none"
        lines.append(f"- {name}: keys {keys}.")
    schema = json.dumps(PlannerCommand.model_json_schema())
    return (
        "You turn an instruction into one command for a robot arm. Answer with one JSON "
        "object and nothing else, matching this JSON schema:\n" + schema + "\n"
        f"Scene objects: {', '.join(scene.get('objects', [])) or 'none'}. "
        f"Markers: {', '.join(scene.get('markers', [])) or 'none'}. "
        "Positions are [x, y, z] in metres in the world frame.\nMachines:\n" + "\n".join(lines)
    )


def parse_reply(text: str) -> PlannerCommand:
    """The planner's text -> a `PlannerCommand` (a ```json fence around it is tolerated).

    Raises:
        PlannerError: Not JSON, a number that is not finite, not an object, or not the schema
            (extra fields included).
    """
    body = text.strip()
    fenced = re.fullmatch(r"```(?:json)?\s*(.*?)\s*```", body, flags=re.S)
    if fenced:
        body = fenced.group(1)
    try:
        data = json.loads(body, parse_constant=_not_finite, parse_float=_finite)
    except json.JSONDecodeError:
        raise PlannerError(f"the planner did not answer with JSON: {text[:120]!r}") from None
    except ValueError as exc:
        raise PlannerError(f"the planner's command is invalid: {exc}") from None
    try:
        return PlannerCommand.model_validate(data)
    except ValidationError as exc:
        problems = "; ".join(
            f"{'.'.join(str(p) for p in e['loc']) or 'reply'}: {e['msg']}" for e in exc.errors()
        )
        raise PlannerError(f"the planner's command is invalid: {problems}") from None


def _not_finite(name: str) -> Any:
    """`json.loads` calls this for `NaN`, `Infinity` and `-Infinity` (not JSON, but Python's
    parser takes them): refused."""
    raise ValueError(f"{name}: not finite (numbers must be finite)")


def _finite(text: str) -> float:
    """A JSON number as a float, refused if it overflows to infinity (`1e400`)."""
    value = float(text)
    if not math.isfinite(value):
        raise ValueError(f"{text[:40]}: not finite (numbers must be finite)")
    return value


def planner_url() -> str:
    """The configured API base.

    Raises:
        PlannerError: `ORCHESTRATOR_PLANNER_URL` is not set.
    """
    url = os.environ.get("ORCHESTRATOR_PLANNER_URL", "").strip()
    if not url:
        raise PlannerError(
            "no planner configured: set ORCHESTRATOR_PLANNER_URL to an OpenAI-compatible API "
            "base (e.g. http://127.0.0.1:8080/v1), and ORCHESTRATOR_PLANNER_MODEL / _KEY"
        )
    return url


def _chat(instruction: str, scene: dict[str, Any]) -> str:
    import httpx

    url = planner_url()
    headers = {}
    if os.environ.get("ORCHESTRATOR_PLANNER_KEY"):
        headers["Authorization"] = f"Bearer {os.environ['ORCHESTRATOR_PLANNER_KEY']}"
    body = {
        "model": os.environ.get("ORCHESTRATOR_PLANNER_MODEL", "default"),
        "temperature": 0,
        "messages": [
            {"role": "system", "content": system_prompt(scene)},
            {"role": "user", "content": instruction},
        ],
    }
    endpoint = url.rstrip("/") + "/chat/completions"
    try:
        resp = httpx.post(endpoint, json=body, headers=headers, timeout=TIMEOUT_S)
        resp.raise_for_status()
        return str(resp.json()["choices"][0]["message"]["content"])
    except httpx.HTTPError as exc:
        raise PlannerError(f"the planner at {endpoint} failed: {exc}") from None
    except (KeyError, IndexError, TypeError, ValueError):
        raise PlannerError(f"the planner at {endpoint} sent no chat completion") from None


def ask_planner(
    client: Client, instruction: str, wait: bool = False
) -> tuple[dict[str, Any], Reply, dict[str, Any] | None]:
    """Ask the planner, submit its command through the session's guardrails.

    Returns:
        The proposal (as JSON), the session's reply, and the task's result if `wait`.

    Raises:
        PlannerError: No planner, or its reply is not a valid command (nothing is sent).
    """
    status = client.status()
    text = _chat(instruction, status.get("scene", {}))
    proposal = parse_reply(text)
    if proposal.machine not in TASK_MACHINES:
        raise PlannerError(
            f"the planner proposes machine {proposal.machine!r} (valid: {', '.join(TASK_MACHINES)})"
        )
    reply, result = client.run(proposal.machine, proposal.as_sets(), wait=wait)
    return proposal.model_dump(), reply, result
