"""Starting a Rerun viewer for live streaming, and telling whether it came up."""

from __future__ import annotations

import socket

import rerun as rr

__all__ = ["spawn_viewer", "viewer_url"]


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
