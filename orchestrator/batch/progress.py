"""The live progress bar: episodes done, success rate so far, elapsed time and ETA."""

from __future__ import annotations

from typing import Any, Protocol

from rich.console import Console
from rich.progress import (
    BarColumn,
    MofNCompleteColumn,
    Progress,
    TaskID,
    TextColumn,
    TimeElapsedColumn,
    TimeRemainingColumn,
)

__all__ = ["BatchProgress", "NullProgress", "RichProgress"]


class BatchProgress(Protocol):
    """Told about the batch as it runs (the runner calls these in this order)."""

    def start(self, total: int, finished: list[dict[str, Any]]) -> None:
        """The batch has `total` episodes; `finished` were done before (a resumed batch)."""

    def advance(self, line: dict[str, Any]) -> None:
        """One more episode finished with this result line."""

    def stop(self) -> None:
        """The batch ended (also on an error or an interrupt)."""


class NullProgress:
    """Shows nothing (stdout is not a terminal, or `--json`)."""

    def start(self, total: int, finished: list[dict[str, Any]]) -> None:
        del total, finished

    def advance(self, line: dict[str, Any]) -> None:
        del line

    def stop(self) -> None:
        pass


class RichProgress:
    """A rich progress bar with the live success rate and the ETA.

    Args:
        console: Where to draw it (stdout by default).
        label: Text before the bar, e.g. the scenario's name.
    """

    def __init__(self, console: Console | None = None, label: str = "batch") -> None:
        self.label = label
        self.progress = Progress(
            TextColumn("[bold]{task.description}"),
            BarColumn(),
            MofNCompleteColumn(),
            TextColumn("{task.fields[rate]}"),
            TimeElapsedColumn(),
            TextColumn("ETA"),
            TimeRemainingColumn(),
            console=console,
            refresh_per_second=4,
        )
        self.task: TaskID | None = None
        self.succeeded = 0
        self.done = 0
        self.not_ok = 0

    def start(self, total: int, finished: list[dict[str, Any]]) -> None:
        for line in finished:
            self._count(line)
        self.progress.start()
        self.task = self.progress.add_task(
            self.label, total=total, completed=self.done, rate=self._rate()
        )

    def advance(self, line: dict[str, Any]) -> None:
        self._count(line)
        if self.task is not None:
            self.progress.update(self.task, advance=1, rate=self._rate())

    def stop(self) -> None:
        self.progress.stop()

    def _count(self, line: dict[str, Any]) -> None:
        self.done += 1
        if line.get("outcome") == "succeeded":
            self.succeeded += 1
        else:
            self.not_ok += 1

    def _rate(self) -> str:
        if not self.done:
            return "success  --.-%"
        style = "green" if self.not_ok == 0 else "yellow"
        pct = 100.0 * self.succeeded / self.done
        return f"success [{style}]{pct:5.1f}%[/] ({self.not_ok} not ok)"
