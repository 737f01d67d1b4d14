"""Snapshots of a user's own scenario: the stacking cell of docs/success-checks.md, with its
own success check (`aligned`, from the scenario's `skills:` folder), broken at a state and
resumed in a fresh process ends exactly as the uninterrupted run; the snapshot never decides
which code runs (the scenario's code folders are imported only when the user names it)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from orchestrator.engine.snapshot.signing import KEY_ENV

from .test_success_checks import _write_page


@pytest.fixture(scope="module")
def cell(tmp_path_factory) -> tuple[Path, dict, Path]:
    """The page's files, the uninterrupted run's JSON and a snapshot taken at CARRY's entry
    (each in a fresh process, as a user runs them)."""
    folder = tmp_path_factory.mktemp("cell")
    _write_page(folder)
    env = {**os.environ, "XDG_CONFIG_HOME": str(folder / "config")}
    env.pop(KEY_ENV, None)
    scenario = str(folder / "stack_cell.yaml")
    full = _orchestrator(env, "run", scenario, "--seed", "1", "--json")
    assert full.returncode == 0, full.stderr
    snap = folder / "carry.snap"
    broke = _orchestrator(env, "run", scenario, "--seed", "1", "--break", "CARRY",
                          "--snapshot", str(snap))  # fmt: skip
    assert broke.returncode == 6, broke.stderr
    return folder, json.loads(full.stdout), snap


def _orchestrator(env: dict, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "orchestrator.cli", *args], env=env,
                          capture_output=True, text=True, check=False, timeout=300)  # fmt: skip


def _env(folder: Path) -> dict:
    env = {**os.environ, "XDG_CONFIG_HOME": str(folder / "config")}
    env.pop(KEY_ENV, None)
    return env


@pytest.mark.slow  # a stacking run resumed in a process of its own (~6 s); in the default run:
# tests/test_snapshot_restore.py's user's skill and check resumed from their data
def test_a_scenario_with_its_own_check_resumes_to_the_uninterrupted_result(cell):
    folder, full, snap = cell
    scenario = str(folder / "stack_cell.yaml")
    res = _orchestrator(_env(folder), "run", scenario, "--from", str(snap), "--json")
    assert res.returncode == 0, res.stderr
    resumed = json.loads(res.stdout)
    assert set(resumed["success"]) >= {"turned_alike"}  # the page's own check judged it
    resumed.pop("wall_time"), full.pop("wall_time", None)
    # measured from the resume on (docs/invariants.md): its own section, not the full run's
    assert resumed.pop("invariants")["from_t"] > 0.0 and full.pop("invariants", None) is not None
    assert resumed == full


def test_a_snapshot_never_imports_the_code_of_its_scenario_unasked(cell):
    folder, _, snap = cell
    res = _orchestrator(_env(folder), "run", "--from", str(snap))
    said = " ".join(res.stderr.split())
    assert res.returncode == 2 and "Traceback" not in res.stderr
    assert "imports code from its skills: folders" in said
    assert f"orchestrator run {folder / 'stack_cell.yaml'} --from {snap}" in said
