"""Where a batch's episodes run: local worker processes or Ray tasks."""

from __future__ import annotations

from ..config import BackendName
from .base import Backend, RunFn
from .local import LocalBackend

__all__ = ["Backend", "LocalBackend", "RunFn", "make_backend"]


def make_backend(name: BackendName, workers: int | None, address: str | None = None) -> Backend:
    """The backend called `name`.

    Args:
        name: `local` or `ray`.
        workers: Worker processes, or CPUs of a local Ray; None: every core (local), the
            cluster's CPUs (Ray).
        address: Ray cluster address (Ray only).

    Raises:
        BatchError: Ray was asked for and is not installed.
    """
    if name == "ray":
        from .ray import RayBackend

        return RayBackend(workers, address)
    from ..config import default_workers

    return LocalBackend(workers if workers is not None else default_workers())
