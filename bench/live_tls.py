"""Mutual TLS on a live session (issue 39, point 6): figures for BENCHMARKS.md, end to end
through the command line, on 127.0.0.1 only.

Certificates are made in a temporary folder (tests/tls_certs.py): a CA, the session's
certificate, an operator's; and the wrong kinds: none, another CA's, self-signed, expired.
`orchestrator serve` runs as a subprocess on `tls/127.0.0.1:PORT` with `--tls-cert`,
`--tls-key`, `--tls-ca`. The operator (`orchestrator send`, certificate from the environment)
takes a snapshot and e-stops; then each wrong kind tries `reset`, `restore` and `run`: exit
code, wall time, and the session's state and the tool's position (from the status, by the
operator) before and after. Then the operator resets, restores and runs a task to its end.
Last, `serve` on non-loopback endpoints without mutual TLS: exit code and time to refuse.

    python bench/live_tls.py [--json PATH]
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from tests.live_attacks import free_port  # noqa: E402
from tests.tls_certs import Authority, self_signed  # noqa: E402

NAME = "tlsbench"
CLI = [sys.executable, "-m", "orchestrator.cli"]


def _run(args: list[str], env: dict[str, str]) -> tuple[int, float, str]:
    start = time.monotonic()
    proc = subprocess.run([*CLI, *args], capture_output=True, text=True, env=env, timeout=600,
                          check=False)  # fmt: skip
    return proc.returncode, time.monotonic() - start, (proc.stdout + proc.stderr).strip()


def _status(env: dict[str, str], endpoint: str) -> dict[str, Any]:
    code, _, text = _run(["send", NAME, "status", "--json", "--connect", endpoint], env)
    assert code == 0, text
    return json.loads(text.splitlines()[-1])["status"]


def _moved_mm(a: dict[str, Any], b: dict[str, Any]) -> float:
    return 1000 * math.dist(a["tcp"], b["tcp"])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--json", type=Path, help="Write the figures here too.")
    args = parser.parse_args()
    folder = Path(tempfile.mkdtemp(prefix="live_tls_"))
    cell, rogue = Authority(folder, "cell"), Authority(folder, "rogue")
    server, operator = cell.issue("session", server=True), cell.issue("operator")
    wrong = {"no certificate": None, "another CA": rogue.issue("intruder"),
             "self-signed": self_signed(folder, "mallory"),
             "expired": cell.issue("stale", expired=True)}  # fmt: skip
    base = {**os.environ, "XDG_CONFIG_HOME": str(folder / "config"),
            "ORCHESTRATOR_TLS_CA": str(cell.ca)}  # fmt: skip
    for var in ("CLIENT_CERT", "CLIENT_KEY", "TLS_CERT", "TLS_KEY", "USER", "CREDENTIALS"):
        base.pop(f"ORCHESTRATOR_{var}", None)
    good = {**base, "ORCHESTRATOR_CLIENT_CERT": str(operator.cert),
            "ORCHESTRATOR_CLIENT_KEY": str(operator.key)}  # fmt: skip
    endpoint = f"tls/127.0.0.1:{free_port()}"
    serve = subprocess.Popen(
        [*CLI, "serve", "pick_place", "--session", NAME, "--listen", endpoint,
         "--tls-cert", str(server.cert), "--tls-key", str(server.key), "--tls-ca", str(cell.ca),
         "--snapshots", str(folder / "snaps"), "--speed", "0"],
        env=base, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    figures: dict[str, Any] = {"load": os.getloadavg(), "endpoint": endpoint, "intruders": {}}
    try:
        assert serve.stderr is not None
        print(serve.stderr.readline().strip())  # the ready line
        code, _, text = _run(["send", NAME, "snapshot", "--name", "before", "--connect",
                              endpoint], good)  # fmt: skip
        assert code == 0, text
        time.sleep(1.0)  # written at the next tick
        code, _, text = _run(["send", NAME, "estop", "--connect", endpoint], good)
        assert code == 0, text
        for kind, issued in wrong.items():
            env = dict(base)
            if issued is not None:
                env |= {"ORCHESTRATOR_CLIENT_CERT": str(issued.cert),
                        "ORCHESTRATOR_CLIENT_KEY": str(issued.key)}  # fmt: skip
            before = _status(good, endpoint)
            tries = {}
            for op in (["reset"], ["restore", "--name", "before"], ["run", "home", "--wait"]):
                code, wall, text = _run(["send", NAME, *op, "--connect", endpoint], env)
                refused = "no Zenoh session could be opened" in text
                tries[op[0]] = {"exit": code, "wall_s": round(wall, 2), "refused": refused}
            after = _status(good, endpoint)
            figures["intruders"][kind] = {
                **tries, "state_after": after["state"], "task_after": after["task"],
                "moved_mm": round(_moved_mm(before, after), 3),
                "last_result_unchanged": after["last_result"] == before["last_result"],
            }  # fmt: skip
            print(kind, figures["intruders"][kind], flush=True)
        valid = {}
        for op in (["reset"], ["restore", "--name", "before"], ["run", "home", "--wait"]):
            code, wall, text = _run(["send", NAME, *op, "--connect", endpoint], good)
            valid[op[0]] = {"exit": code, "wall_s": round(wall, 2), "said": text[-120:]}
            time.sleep(0.5)  # reset and restore are applied at the next tick
        figures["operator"] = valid
        print("operator", valid, flush=True)
    finally:
        serve.terminate()
        serve.wait(30)
    refusals = {}
    bare = {k: v for k, v in base.items() if k != "ORCHESTRATOR_TLS_CA"}  # never a full set
    for listen, extra in (("tcp/0.0.0.0", []), ("tls/0.0.0.0", ["--tls-cert", str(server.cert),
                          "--tls-key", str(server.key)])):  # fmt: skip
        code, wall, text = _run(["serve", "pick_place", "--session", "x", "--listen",
                                 f"{listen}:{free_port()}", *extra], bare)  # fmt: skip
        refusals[listen] = {"exit": code, "wall_s": round(wall, 2), "said": text[-160:]}
    figures["refusals"] = refusals
    print("refusals", refusals)
    if args.json:
        args.json.write_text(json.dumps(figures, indent=2))


if __name__ == "__main__":
    main()
