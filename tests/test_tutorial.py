"""A new user's first ten minutes: the tutorial and the README's "Your first flow", played.

In an empty folder, the files the page shows are written (a skill in a local folder, a machine
that picks the cube, places it where `--set place_at` says and goes home, a scenario) and the
page's commands are run through the installed CLI, exactly as printed. They must succeed.
"""

from __future__ import annotations

import json
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parent.parent
PAGES = [REPO / "docs" / "tutorial-first-flow.md", REPO / "README.md"]
_BLOCK = re.compile(r"<!-- (file: (?P<file>\S+)|run) -->\n```\w*\n(?P<body>.*?)```", re.S)


def _steps(page: Path, section: str | None) -> list[tuple[str, str]]:
    text = page.read_text()
    if section is not None:
        text = text[text.index(section) :]
        text = text[: text.find("\n## ", 1)]
    return [(m.group("file") or "run", m.group("body")) for m in _BLOCK.finditer(text)]


def _run(line: str, cwd: Path) -> subprocess.CompletedProcess:
    argv = shlex.split(line)
    assert argv[0] == "orchestrator", line
    redirect = None
    if ">" in argv:
        redirect = cwd / argv[argv.index(">") + 1]
        argv = argv[: argv.index(">")]
    proc = subprocess.run(
        [sys.executable, "-m", "orchestrator.cli", *argv[1:]],
        cwd=cwd,
        capture_output=True,
        text=True,
        timeout=600,
        check=False,
    )
    if redirect is not None:
        redirect.write_text(proc.stdout)
    return proc


@pytest.mark.parametrize(
    ("page", "section"),
    [
        # the tutorial's seven commands (a batch among them) take ~30 s: the slow suite plays
        # them; the default run plays the README's flow and runs the tutorial's cell and skill
        # (the two tests below)
        pytest.param(PAGES[0], None, marks=pytest.mark.slow),
        (PAGES[1], "## Your first flow"),
    ],
    ids=["tutorial", "readme"],
)
def test_a_new_user_follows_the_page_and_every_command_succeeds(tmp_path, page, section):
    steps = _steps(page, section)
    files = [name for name, _ in steps if name != "run"]
    assert {"my_skills/wait.py", "my_flow.yaml", "my_cell.yaml"} <= set(files), files
    commands = 0
    for name, body in steps:
        if name != "run":
            (tmp_path / name).parent.mkdir(parents=True, exist_ok=True)
            (tmp_path / name).write_text(body)
            continue
        for line in body.splitlines():
            if not line.strip() or line.startswith("#"):
                continue
            proc = _run(line, tmp_path)
            commands += 1
            assert proc.returncode == 0, f"{line}\n{proc.stdout}\n{proc.stderr}"
            assert "Traceback" not in proc.stderr
            if " run " in f" {line} ":
                assert "succeeded in DONE" in proc.stdout, proc.stdout
    assert commands >= 2


def test_the_placed_check_follows_place_at_and_says_by_how_much(tmp_path):
    for name, body in _steps(PAGES[0], None):
        if name != "run":
            (tmp_path / name).parent.mkdir(parents=True, exist_ok=True)
            (tmp_path / name).write_text(body)
    # judged at the pad while the flow places 15 cm away: fails, saying which check and how far
    cell = (tmp_path / "my_cell.yaml").read_text().replace("target: $place_at", "target: pad")
    (tmp_path / "pad_cell.yaml").write_text(cell)
    proc = _run("orchestrator run pad_cell.yaml --json --set place_at=[0.35,0.25,0.2]", tmp_path)
    assert proc.returncode == 1, proc.stderr
    result = json.loads(proc.stdout)
    assert result["outcome"] == "failed" and result["success"]["placed"] is False
    detail = result["success_detail"]["placed"]
    mm = float(re.search(r"cube is ([0-9.]+) mm from \[0.5, 0.2\] \(xy_tol_m 10 mm\)", detail)[1])
    assert 140.0 < mm < 170.0, detail  # |(0.35, 0.25) - (0.5, 0.2)| = 158 mm


def test_the_readme_set_example_moves_the_cube_and_the_check_follows(cli):
    example = "place_at=[0.4,0.28,0.2]"
    assert f"`--set {example}`" in PAGES[1].read_text()
    res = cli("run", "pick_place", "--json", "--set", example)
    assert res.exit_code == 0, res.stdout
    detail = res.json["success_detail"]["cube_on_target"]
    assert "mm from [0.4, 0.28]" in detail, detail


def _cell_guards(page: Path, section: str | None) -> dict:
    import yaml

    files = dict(_steps(page, section))
    return yaml.safe_load(files["my_cell.yaml"])["guards"]


@pytest.mark.parametrize(
    ("page", "section"),
    [(PAGES[0], None), (PAGES[1], "## Your first flow")],
    ids=["tutorial", "readme"],
)
def test_the_pages_cells_have_the_guards_of_the_default_scene(page, section):
    # a skill that passes `run my_flow.yaml` (the default scene) is held to the same limits
    from orchestrator.language.default_scene import DEFAULT_SCENARIO

    assert _cell_guards(page, section) == DEFAULT_SCENARIO["guards"]


WAIT_ONLY = """\
name: wait_only
initial: WAIT
states:
  WAIT:
    skill: {skill}
    with: {{seconds: 1.0}}
    transitions: {{done: DONE}}
  DONE: {{final: succeeded}}
"""


def _wait_ends(cli, folder: Path, skill: str) -> tuple[float, dict]:
    (folder / "m.yaml").write_text(WAIT_ONLY.format(skill=skill))
    res = cli(
        "run", str(folder / "m.yaml"), "--skills", str(folder / "my_skills"), "--json",
        "--event", "0.8:pause", "--event", "2.8:resume",
    )  # fmt: skip
    assert res.exit_code == 0, res.stderr
    (end,) = [t["t"] for t in res.json["transitions"] if t["from"] == "WAIT"]
    return end, res.json["metrics"]


def test_the_pages_wait_stands_still_while_the_run_is_paused(cli, tmp_path):
    # the tutorial's own `wait`, paused at 0.8 s for 2 s: it waits 1 s of the skills' clock
    body = dict(_steps(PAGES[0], None))["my_skills/wait.py"]
    (tmp_path / "my_skills").mkdir()
    (tmp_path / "my_skills" / "wait.py").write_text(body)
    end, metrics = _wait_ends(cli, tmp_path, "wait")
    assert metrics["paused_s"] == pytest.approx(2.0, abs=0.011)  # up to a control tick
    assert 1.0 + metrics["paused_s"] <= end + 1e-9 <= 1.0 + metrics["paused_s"] + 0.011
    # the same skill on simulated time (`ctx.t`) ends during the pause: what the clock fixes
    on_t = body.replace("ctx.clock", "ctx.t").replace(
        'name: ClassVar[str] = "wait"', 'name: ClassVar[str] = "wait_t"'
    )
    (tmp_path / "on_t" / "my_skills").mkdir(parents=True)
    (tmp_path / "on_t" / "my_skills" / "wait.py").write_text(on_t)
    end_t, _ = _wait_ends(cli, tmp_path / "on_t", "wait_t")
    assert 0.8 < end_t < 2.8, end_t
