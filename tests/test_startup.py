"""Start-up stays cheap: commands that only read files load no physics, IK or vision library.

`validate` needs the language layer and the skills' (guards', checks', robots')
*declarations* — names, `Params`, outcomes, joint names — and nothing that runs them. A fresh
interpreter runs the command in-process and then reports which heavy libraries its
`sys.modules` holds: a skill (or guard, robot, check) module that imports MuJoCo, pinocchio,
mink or OpenCV at its top again makes this fail, naming the library. bench/startup.py
measures what the rule saves (docs/performance.md, "Start-up").
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
HEAVY = ("mujoco", "pinocchio", "mink", "qpsolvers", "scipy", "cv2", "ruckig", "rerun", "zenoh")
"""Libraries a command that simulates nothing must not import."""
COMMANDS = [
    ["--version"],
    ["validate", str(REPO / "tests" / "machines" / "small_move.yaml")],
    ["validate", str(REPO / "machines" / "pick_place.yaml")],
    ["show", "skill", "move"],
    ["list", "skills"],
]
"""Run in this order in one interpreter: what one leaves loaded, the ones after it see."""
PROBE = """\
import json, sys
from orchestrator.cli import main
commands, heavy = json.loads(sys.argv[1]), json.loads(sys.argv[2])
out = []
for args in commands:
    sys.argv = ["orchestrator", *args]
    try:
        main()
        code = 0
    except SystemExit as exc:
        code = exc.code
    out.append({"args": args, "exit": code, "loaded": [m for m in heavy if m in sys.modules]})
print(json.dumps(out))
"""
"""Runs the commands in-process, one after the other; after each, the heavy libraries that
`sys.modules` holds."""


def test_reading_commands_load_no_physics_ik_or_vision_library(tmp_path: Path):
    proc = subprocess.run(
        [sys.executable, "-c", PROBE, json.dumps(COMMANDS), json.dumps(HEAVY)],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        check=False,
        timeout=120,
    )
    assert proc.returncode == 0, proc.stderr
    for step in json.loads(proc.stdout.splitlines()[-1]):
        command = f"orchestrator {' '.join(step['args'])}"
        assert step["exit"] == 0, f"{command} exited {step['exit']}: {proc.stdout}"
        assert step["loaded"] == [], (
            f"{command} imported {step['loaded']}: import them in the functions that use "
            "them (docs/performance.md, 'Start-up')"
        )
