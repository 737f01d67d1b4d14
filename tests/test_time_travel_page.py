"""docs/time-travel.md, played: its files are written and its commands run, in order, as
printed, each with the exit code the page says (`<!-- run: exit N -->`, else 0)."""

from __future__ import annotations

import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

from orchestrator.engine.snapshot.signing import KEY_ENV

PAGE = Path(__file__).resolve().parent.parent / "docs" / "time-travel.md"
_BLOCK = re.compile(
    r"<!-- (file: (?P<file>\S+)|run(: exit (?P<exit>\d+))?) -->\n```\w*\n(?P<body>.*?)```", re.S
)


def _play(line: str, cwd: Path, cli) -> tuple[int, str]:
    argv = shlex.split(line)
    redirect = None
    if ">" in argv:
        redirect = cwd / argv[argv.index(">") + 1]
        argv = argv[: argv.index(">")]
    if argv[0] == "orchestrator":  # in process: the same entry point, without the start-up
        res = cli(*argv[1:])
        code, out, err = res.exit_code, res.stdout, res.stderr
    else:
        assert argv[0] == "python", line
        proc = subprocess.run([sys.executable, *argv[1:]], cwd=cwd, capture_output=True,
                              text=True, check=False)  # fmt: skip
        code, out, err = proc.returncode, proc.stdout, proc.stderr
    if redirect is not None:
        redirect.write_text(out)
    assert "Traceback" not in err, err
    return code, out + err


def test_the_time_travel_page_runs_as_written(tmp_path, monkeypatch, cli):
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv(KEY_ENV, raising=False)
    monkeypatch.setenv("XDG_CONFIG_HOME", str(tmp_path / "config"))
    said: list[str] = []
    blocks = list(_BLOCK.finditer(PAGE.read_text()))
    assert len(blocks) >= 6
    for block in blocks:  # the page's files first: a command may use one shown after it
        if block.group("file"):
            (tmp_path / block.group("file")).write_text(block.group("body"))
    for block in blocks:
        if block.group("file"):
            continue
        want = int(block.group("exit") or 0)
        for line in block.group("body").splitlines():
            if line.strip() and not line.startswith("#"):
                code, output = _play(line, tmp_path, cli)
                assert code == want, f"{line}: exit {code}, the page says {want}\n{output}"
                said.append(output)
    text = "\n".join(said)
    _figures_match_the_run(text)
    assert "snapshot written to before_grasp.snap" in text
    assert "identical" in text  # the resumed run is the uninterrupted one
    assert "failed in FAILED" in text and "succeeded in DONE" in text  # the two variations


FIGURE_TOLERANCE = 0.02
"""The page's figure against the run's, relative: room for the last bits a contact-rich
run changes on another CPU or library version, not for a stale figure (the page's old
60.3 N against the run's 62.25 N was 3 % off)."""


def _figures_match_the_run(output: str) -> None:
    """The page's figures are the runs': the acceleration the guard aborted at (within
    `FIGURE_TOLERANCE`), and a run's printed times say which is the command's and which the
    episode's."""
    page = PAGE.read_text()
    said = re.search(r"aborts the run\s+in `TRANSPORT` with joint 2 at ([\d.]+) rad/s", page)
    ran = re.search(r"aborted by joint_acceleration: joint 2 at -?([\d.]+) rad/s", output)
    assert said and ran, output
    assert float(said.group(1)) == pytest.approx(float(ran.group(1)), rel=FIGURE_TOLERANCE)
    times = re.findall(r"\(([\d.]+) s for the command with its start-up: the episode ([\d.]+) s "
                       r"wall, \d+x real time\)", output)  # fmt: skip
    assert times, output
    for command, episode in times:
        assert float(command) >= float(episode)  # the command includes the episode
