"""The goal guardrail a live session's commands go through: it lives in the engine
(`orchestrator/engine/guardrail.py`), where `prepare` (engine/prepare.py) applies the same
checks to `run`, `batch`, `faults` and time travel; re-exported here for the session's code."""

from __future__ import annotations

from ..engine.guardrail import REACH_TOL_M, GoalRejected, check_goals, is_finite, posed_keys

__all__ = ["REACH_TOL_M", "GoalRejected", "check_goals", "is_finite", "posed_keys"]
