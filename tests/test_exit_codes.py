"""One exit-code table (README's), honoured on every command path that can end with it."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

README = Path(__file__).resolve().parents[1] / "README.md"


def _table() -> dict[str, int]:
    """README's exit-code table: the first words of each row's meaning -> its code."""
    text = README.read_text()
    block = text[text.index("<!-- exit-codes -->") :].split("\n\n", 1)[0]
    rows = re.findall(r"^\| `(\d+)` \| (.+) \|$", block, re.M)
    assert len(rows) >= 8, block
    return {what: int(code) for code, what in rows}


def _code(fragment: str) -> int:
    matches = [code for what, code in _table().items() if what.startswith(fragment)]
    assert len(matches) == 1, (fragment, _table())
    return matches[0]


def test_the_table_has_one_code_per_meaning():
    codes = list(_table().values())
    assert len(codes) == len(set(codes))


def test_run_paths_exit_with_the_table_codes(cli, tmp_path):
    assert cli("validate", "pick_place").exit_code == _code("succeeded")
    assert cli("run", "no_such_scenario").exit_code == _code("invalid input")
    failed = cli("run", "pick_place", "--set", "physics.time_limit_s=0.3", "--json")
    assert failed.exit_code == _code("the task failed"), failed.stderr
    aborted = cli("run", "pick_place", "--fault", "estop@0.3", "--json")
    assert aborted.exit_code == _code("aborted by a guard"), aborted.stderr
    walled = cli("run", "pick_place", "--max-wall-s", "0.05", "--json")
    assert walled.exit_code == _code("outcome `error`"), walled.stderr
    assert walled.json["outcome"] == "error"


def test_a_resumed_run_past_its_wall_limit_exits_as_an_error(cli, tmp_path):
    snap = tmp_path / "grasp.snap"
    broke = cli("run", "pick_place", "--break-at", "0.5", "--snapshot", str(snap))
    assert broke.exit_code == _code("`run --break`"), broke.stderr
    resumed = cli("run", "pick_place", "--from", str(snap), "--max-wall-s", "0.05")
    assert resumed.exit_code == _code("outcome `error`"), resumed.stderr
    assert "wall-clock limit" in resumed.stderr


def test_a_batch_with_an_error_episode_exits_1(cli, tmp_path):
    res = cli(
        "batch", "pick_place", "-n", "1", "--workers", "1", "--max-wall-s", "0.05",
        "--out", str(tmp_path / "b"), "--record", "none",
    )  # fmt: skip
    assert res.exit_code == _code("the task failed"), res.stderr


@pytest.mark.parametrize(
    "args",
    [("list",),  # the default suite; the other two (~2 s each) in the slow one
     pytest.param(("validate", "pick_place"), marks=pytest.mark.slow),
     pytest.param(("run", "pick_place", "--json", "--set", "physics.time_limit_s=0.2"),
                  marks=pytest.mark.slow)],
)  # fmt: skip
def test_a_closed_stdout_exits_with_the_pipe_code_and_no_traceback(args):
    # the reader is gone before the command writes a byte (`| head -c1` that already exited)
    proc = subprocess.Popen(
        [sys.executable, "-c", "import sys; from orchestrator.cli import main; sys.argv[0] = "
         "'orchestrator'; main()", *args],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE,
    )  # fmt: skip
    proc.stdout.close()  # type: ignore[union-attr]
    stderr = proc.stderr.read().decode()  # type: ignore[union-attr]
    assert proc.wait(timeout=300) == _code("whoever read stdout closed it"), stderr
    assert "Traceback" not in stderr and "Exception ignored" not in stderr
