"""Starting a Rerun viewer for live streaming, and telling whether it came up."""

from __future__ import annotations

import socket
from urllib.parse import urlsplit

import rerun as rr

from .exceptions import RecordingError

__all__ = ["connect_url", "reachable", "spawn_viewer", "viewer_url"]

_SCHEMES = ("rerun", "rerun+http", "rerun+https")


def viewer_url(port: int) -> str:
    """The gRPC address a viewer spawned on `port` listens on."""
    return f"rerun+http://127.0.0.1:{port}/proxy"


def spawn_viewer(rec: rr.RecordingStream, port: int, timeout_s: float = 0.5) -> bool:
    """Start a Rerun viewer (or reuse one already listening on `port`).

    Args:
        rec: The recording stream the viewer is for.
        port: TCP port of the viewer.
        timeout_s: How long to wait for the port to accept a connection [s].

    Returns:
        True if a viewer accepts connections on `port`; False if none came up (no display,
        no `rerun` executable): streaming to it would only stall the run.
    """
    rec.spawn(port=port, connect=False)
    try:
        with socket.create_connection(("127.0.0.1", port), timeout=timeout_s):
            return True
    except OSError:
        return False


def connect_url(target: str) -> str:
    """The gRPC address of a running viewer or `rerun --serve-web` server, from a URL or a
    port (`9876` -> `rerun+http://127.0.0.1:9876/proxy`, as `rerun --connect` reads it).

    Raises:
        RecordingError: Neither a port nor a `rerun+http://HOST:PORT/proxy` URL.
    """
    if target.isdigit():
        return viewer_url(int(target))
    parts = urlsplit(target)
    if parts.scheme not in _SCHEMES or parts.path != "/proxy" or not parts.hostname:
        raise RecordingError(
            f"--connect {target!r}: not a Rerun address (valid: a port, or"
            " rerun+http://HOST:PORT/proxy, rerun+https://..., rerun://...)"
        )
    return target


def reachable(url: str, timeout_s: float = 0.5) -> bool:
    """True if something accepts TCP connections at the host and port of gRPC `url`."""
    parts = urlsplit(url)
    port = parts.port or (443 if parts.scheme == "rerun+https" else 9876)
    try:
        with socket.create_connection((parts.hostname or "127.0.0.1", port), timeout=timeout_s):
            return True
    except OSError:
        return False
