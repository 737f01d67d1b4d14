"""Start-up stays cheap: commands that only read files load no physics, IK or vision library.

`validate` needs the language layer and the skills' (guards', checks', robots')
*declarations* — names, `Params`, outcomes, joint names — and nothing that runs them. A fresh
interpreter runs the command in-process and then reports which heavy libraries its
`sys.modules` holds: a skill (or guard, robot, check) module that imports MuJoCo, pinocchio,
mink or OpenCV at its top again makes this fail, naming the library. Validating a machine
imports only the modules of the skills it uses and no scenario model (`language/machines.py`
holds its entry point), `--version` and a clean `validate` print plain lines without rich, and
the installed entry points are read once per process by the project (a library's own reads,
which vary with its version, are not counted).
bench/startup.py measures what the rules save (docs/performance.md, "Start-up").
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
HEAVY = ("mujoco", "pinocchio", "mink", "qpsolvers", "scipy", "cv2", "ruckig", "rerun", "zenoh")
"""Libraries a command that simulates nothing must not import."""
SCENARIO_SIDE = (
    "orchestrator.language.scenario",
    "orchestrator.language.scene",
    "orchestrator.language.faults",
    "orchestrator.language.load",
    "orchestrator.language.scenario_checks",
)
"""A scenario's models and checks: validating a machine uses none of them."""
UNUSED_SKILLS = tuple(
    f"orchestrator.skills.{m}" for m in ("grasp", "release", "register", "detect", "conveyor")
)
"""Modules of skills the small machine does not use: validating it imports only `move`'s
(skills/registry.py, `BUNDLED`)."""
SMALL = str(REPO / "tests" / "machines" / "small_move.yaml")
"""A user's first machine (bench/startup.py times validating it)."""
COMMANDS = [
    (["--version"], ("numpy", "pydantic", "yaml", "rich.console", *SCENARIO_SIDE)),
    (["validate", SMALL], ("rich.console", "rich.markup", *SCENARIO_SIDE, *UNUSED_SKILLS)),
    (["validate", str(REPO / "machines" / "pick_place.yaml")], ("rich.table", *SCENARIO_SIDE)),
    (["show", "skill", "move"], ()),
    (["list", "skills"], ()),
]  # fmt: skip
"""Run in this order in one interpreter: what one leaves loaded, the ones after it see. With
each, besides `HEAVY`, the modules it must not have loaded."""
PROBE = """\
import importlib.metadata, json, sys
reads = []
read = importlib.metadata.entry_points
def counted(**params):
    # the project's own reads only: libraries (typer's, pydantic's plugins...) read entry
    # points too, as often as their version does
    if sys._getframe(1).f_globals.get("__name__", "").startswith("orchestrator."):
        reads.append(params)
    return read(**params)
importlib.metadata.entry_points = counted
from orchestrator.cli import main
commands, heavy = json.loads(sys.argv[1]), json.loads(sys.argv[2])
out = []
for args, also in commands:
    sys.argv = ["orchestrator", *args]
    try:
        main()
        code = 0
    except SystemExit as exc:
        code = exc.code
    out.append({
        "args": args,
        "exit": code,
        "loaded": [m for m in heavy if m in sys.modules],
        "also": [m for m in also if m in sys.modules],
        "entry point reads": len(reads),
    })
print(json.dumps(out))
"""
"""Runs the commands in-process, one after the other; after each, the heavy libraries that
`sys.modules` holds."""


def _probe(tmp_path: Path) -> list[dict]:
    """Each command's exit code and what it left loaded (`PROBE`), in a fresh interpreter."""
    proc = subprocess.run(
        [sys.executable, "-c", PROBE, json.dumps(COMMANDS), json.dumps(HEAVY)],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        check=False,
        timeout=120,
    )
    assert proc.returncode == 0, proc.stderr
    steps: list[dict] = json.loads(proc.stdout.splitlines()[-1])
    for step in steps:
        command = f"orchestrator {' '.join(step['args'])}"
        assert step["exit"] == 0, f"{command} exited {step['exit']}: {proc.stdout}"
    return steps


def test_reading_commands_load_no_physics_ik_or_vision_library(tmp_path: Path):
    steps = _probe(tmp_path)
    for step in steps:
        command = f"orchestrator {' '.join(step['args'])}"
        assert step["loaded"] == [], (
            f"{command} imported {step['loaded']}: import them in the functions that use "
            "them (docs/performance.md, 'Start-up')"
        )
        assert step["also"] == [], (
            f"{command} imported {step['also']}, which it does not use: import them where "
            "they are used (docs/performance.md, 'Start-up')"
        )
    # `--version` reads none; `validate` reads them once for the skills and the checks both
    assert [s["entry point reads"] for s in steps] == [0, 1, 1, 1, 1]


def test_the_commands_annotations_are_objects_not_strings():
    """typer reads every command's parameter annotations at each start; written as strings
    (`from __future__ import annotations` in the cli package) each is compiled and evaluated
    again."""
    from orchestrator.cli import app

    commands = [*app.registered_commands]
    for group in app.registered_groups:  # `snapshot show|list`
        commands += group.typer_instance.registered_commands
    callbacks = [c.callback for c in commands if c.callback is not None]
    assert len(callbacks) == len(commands) > 10
    for callback in callbacks:
        strings = {k: v for k, v in callback.__annotations__.items() if isinstance(v, str)}
        assert strings == {}, f"{callback.__name__}: annotations as strings {strings}"
