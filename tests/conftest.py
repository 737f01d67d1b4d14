"""Shared fixtures: loaded scenarios, a CLI runner, small scenario files."""

from __future__ import annotations

import json
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import pytest

if TYPE_CHECKING:
    from orchestrator.language.load import LoadedScenario

# The suite writes bytecode caches (`__pycache__/`, gitignored) even where
# PYTHONDONTWRITEBYTECODE is set: otherwise each xdist worker compiles the package and the
# tests anew (collection 10-11 s CPU -> 6), and every CLI subprocess compiles what it imports
# (`validate`: ~0.4 s more). Set before the package's modules are imported: this module
# imports none of them (its fixtures do).
sys.dont_write_bytecode = False

DATA = Path(__file__).parent / "data"
RESULT_KEYS = (
    "scenario",
    "seed",
    "outcome",
    "final_state",
    "reason",
    "sim_time",
    "wall_time",
    "transitions",
    "metrics",
    "success",
)
"""The keys of `run --json`, in the order DESIGN.md fixes (the contract checks rely on)."""
REPO = Path(__file__).resolve().parent.parent


@dataclass
class CliResult:
    exit_code: int
    stdout: str
    stderr: str
    exception: BaseException | None = None

    @property
    def json(self) -> dict:
        return json.loads(self.stdout)


@pytest.fixture(scope="session")
def pick_place() -> LoadedScenario:
    from orchestrator.language.load import load_scenario

    return load_scenario("pick_place")


@pytest.fixture
def cli():
    """Run the CLI in-process; the result has exit_code, stdout, stderr, exception."""
    from .cli_runner import invoke as invoke_cli

    def invoke(*args: str) -> CliResult:
        res = invoke_cli(args, catch_exceptions=True)
        exc = res.exception if not isinstance(res.exception, SystemExit) else None
        return CliResult(res.exit_code, res.stdout, res.stderr, exc)

    return invoke


@pytest.fixture
def cli_process():
    """Run the installed `orchestrator` console script in a subprocess."""

    def invoke(*args: str, cwd: Path | None = None) -> CliResult:
        proc = subprocess.run(
            [sys.executable, "-m", "orchestrator.cli", *args],
            check=False,
            capture_output=True,
            text=True,
            cwd=cwd,
            timeout=300,
        )
        return CliResult(proc.returncode, proc.stdout, proc.stderr)

    return invoke


@pytest.fixture
def write_yaml(tmp_path: Path):
    """Write a YAML file into tmp_path and return its path."""

    def write(name: str, text: str) -> Path:
        path = tmp_path / name
        path.write_text(text)
        return path

    return write
