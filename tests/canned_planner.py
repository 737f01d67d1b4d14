"""A local chat-completions server with a canned reply: the planner of the planner tests and of
bench/live_safety.py (loopback only)."""

from __future__ import annotations

import json
import threading
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from typing import ClassVar

__all__ = ["CannedPlanner", "start"]


class CannedPlanner(BaseHTTPRequestHandler):
    """Answers every chat completion with `reply`; keeps the requests it got."""

    reply: ClassVar[str] = ""
    requests: ClassVar[list[dict]] = []

    def do_POST(self) -> None:
        body = json.loads(self.rfile.read(int(self.headers["Content-Length"])))
        CannedPlanner.requests.append(body)
        message = {"role": "assistant", "content": CannedPlanner.reply}
        out = json.dumps({"choices": [{"message": message}]}).encode()
        self.send_response(200)
        self.send_header("Content-Type", "application/json")
        self.send_header("Content-Length", str(len(out)))
        self.end_headers()
        self.wfile.write(out)

    def log_message(self, *args) -> None:
        pass


def start() -> tuple[str, ThreadingHTTPServer]:
    """Serve on 127.0.0.1 (a free port) from a daemon thread: the API base URL and the server
    (`shutdown()` it)."""
    server = ThreadingHTTPServer(("127.0.0.1", 0), CannedPlanner)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    return f"http://127.0.0.1:{server.server_address[1]}/v1", server
