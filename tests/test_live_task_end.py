"""A client that sends its next `run` the moment it hears `task_end` finds the session free.

Found by CI (tests/test_live_robots.py, slow): `run --wait` returned on `task_end`, the next
`run` came back "busy: task … is running". The loop published the event before it let go of
the task, and the channel's thread checked the new `run` in between."""

from __future__ import annotations

from pathlib import Path

from orchestrator.live.protocol import Command
from orchestrator.live.session import Session

from .test_live_estop_ending import SWING, _tick


def test_a_run_sent_on_task_end_is_admitted(tmp_path: Path):
    (tmp_path / "swing.yaml").write_text(SWING)
    machine = str(tmp_path / "swing.yaml")
    answers: list[str | None] = []
    session: Session

    def publish(leaf: str, msg: dict) -> None:
        if leaf == "events" and msg["event"] == "task_end":
            # what the channel's thread does with a `run` that arrives now
            answers.append(session.busy(Command(op="run", machine=machine)))

    session = Session("pick_place", "ends", seed=3, speed=0.0, allow_paths=[tmp_path],
                      publish=publish)  # fmt: skip
    assert session.submit(Command(op="run", machine=machine)).accepted
    for _ in range(400):
        _tick(session)
        if answers:
            break
    assert answers == [None], answers
    assert session.task is None and session.state == "IDLE"
