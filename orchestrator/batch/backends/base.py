"""The Backend base: runs episode tasks somewhere and yields their lines as they finish."""

from __future__ import annotations

import abc
from collections.abc import Callable, Iterator, Sequence
from typing import Any, ClassVar

from ..task import EpisodeTask

__all__ = ["Backend", "RunFn"]

RunFn = Callable[[EpisodeTask], dict[str, Any]]
"""Runs one episode in a worker and returns its line; must never raise (see `run_task`)."""

MAX_ATTEMPTS = 2
"""An episode whose worker dies is run once more, then recorded as `error`."""


class Backend(abc.ABC):
    """Where episodes run. The batch runner owns the results file; a backend only runs.

    Args:
        workers: Episodes running at the same time.
    """

    name: ClassVar[str]

    def __init__(self, workers: int) -> None:
        if workers < 1:
            raise ValueError(f"workers must be >= 1, got {workers}")
        self.workers = workers

    @abc.abstractmethod
    def run(self, tasks: Sequence[EpisodeTask]) -> Iterator[dict[str, Any]]:
        """Run every task; yield each result line as soon as its episode ends (any order).

        Closing the iterator early (an interrupt) stops the workers.
        """
