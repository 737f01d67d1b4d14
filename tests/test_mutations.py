"""The suite sees a broken controller: each mutant of tests/mutants.py (the five breakages the
physical-honesty audit found the suite blind to, and the surgical offset fix removed) must
make the tests fail.

Slow (a child pytest per mutant): `pytest -m slow tests/test_mutations.py`.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from tests.mutants import MUTANTS

ROOT = Path(__file__).resolve().parent.parent
TARGETS = [
    "tests/test_physical_honesty.py",
    "tests/test_controller.py",
    "tests/test_surgical.py",
    "tests/test_pick_place.py",
]
"""The tests that bound what a broken controller changes (whole-episode joint speed, torque,
finger penetration, wrist force, the true incision, the SAFE_HOLD force decay)."""


@pytest.mark.slow
@pytest.mark.parametrize("mutant", sorted(MUTANTS))
def test_the_suite_fails_for_each_mutant(mutant):
    env = {**os.environ, "ORCH_MUTANT": mutant}
    cmd = [sys.executable, "-m", "pytest", "-q", "-x", "-p", "no:cacheprovider"]
    cmd += ["-p", "tests.mutants", "-n", "0", "-m", "not slow", *TARGETS]  # serial: -x stops
    proc = subprocess.run(
        cmd, check=False, cwd=ROOT, env=env, capture_output=True, text=True, timeout=3600
    )
    tail = "\n".join(proc.stdout.splitlines()[-15:])
    assert proc.returncode == 1, f"mutant {mutant!r} went unnoticed:\n{tail}"
