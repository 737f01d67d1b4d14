"""Skills from outside the project: installed plugins (entry points) and local folders."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

WAIT = '''
from typing import ClassVar
from pydantic import Field, PositiveFloat
from orchestrator.skills import Skill, SkillParams


class WaitParams(SkillParams):
    seconds: PositiveFloat = Field(default=0.5, description="How long [s].")


class Wait(Skill):
    """Hold still."""

    name: ClassVar[str] = "{name}"
    Params: ClassVar[type[SkillParams]] = WaitParams
    outcomes: ClassVar[tuple[str, ...]] = ("done",)

    def step(self, ctx):
        return "done"
'''


@pytest.fixture
def plugin_env(tmp_path: Path) -> dict[str, str]:
    """An environment where a fake distribution declares three skill entry points: one that
    fails to import, one that names a module, one that works (`pwait`)."""
    site = tmp_path / "site"
    info = site / "fakeplug-0.1.dist-info"
    info.mkdir(parents=True)
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: fakeplug\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text(
        "[orchestrator.skills]\n"
        "broken = fakeplug_broken:Wait\n"
        "modonly = fakeplug_mod\n"
        "pwait = fakeplug_good:Wait\n"
    )
    (site / "fakeplug_broken.py").write_text("import robot_sdk_that_is_not_installed\n")
    (site / "fakeplug_mod.py").write_text(WAIT.format(name="mwait"))
    (site / "fakeplug_good.py").write_text(WAIT.format(name="pwait"))
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(site), env.get("PYTHONPATH")]))
    return env


def _cli(*args: str, env: dict[str, str] | None = None, cwd: Path | None = None):
    return subprocess.run(
        [sys.executable, "-m", "orchestrator.cli", *args],
        capture_output=True,
        text=True,
        env=env,
        cwd=cwd,
        timeout=300,
        check=False,
    )


def test_a_broken_plugin_is_one_warning_and_every_command_goes_on(plugin_env):
    proc = _cli("list", "skills", env=plugin_env)
    assert proc.returncode == 0, proc.stderr
    assert "Traceback" not in proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 2, proc.stderr
    assert lines[0].startswith(
        "warning: plugin skill 'broken' (fakeplug_broken:Wait, from fakeplug) failed to import"
    )
    assert "ModuleNotFoundError: No module named 'robot_sdk_that_is_not_installed'" in lines[0]
    assert "plugin skill 'modonly' (fakeplug_mod, from fakeplug) names a module" in lines[1]
    assert "pwait" in proc.stdout and "plugin fakeplug_good" in proc.stdout
    assert "mwait" not in proc.stdout


def test_the_schema_command_knows_plugins_but_the_shipped_schema_stays_in_sync(plugin_env):
    proc = _cli("schema", "machine", env=plugin_env)
    assert proc.returncode == 0
    schema = json.loads(proc.stdout)
    assert "pwait" in schema["definitions"]["StateSpec"]["properties"]["skill"]["anyOf"][0]["enum"]
    check = (
        "from orchestrator.language.schema_gen import SCHEMA_DIR, schema_text\n"
        "from orchestrator.skills import skill_names\n"
        "assert 'pwait' in skill_names()\n"
        "for k in ('machine', 'scenario'):\n"
        "    assert (SCHEMA_DIR / f'{k}.schema.json').read_text() == schema_text(k, True), k\n"
    )
    proc = subprocess.run(
        [sys.executable, "-c", check], env=plugin_env, capture_output=True, text=True, check=False
    )
    assert proc.returncode == 0, proc.stderr


def test_show_skill_from_a_local_folder(tmp_path):
    (tmp_path / "mine").mkdir()
    (tmp_path / "mine" / "wait.py").write_text(WAIT.format(name="lwait"))
    proc = _cli("show", "skill", "lwait", "--skills", "mine", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert "| `seconds` | float | s | `0.5` | > 0 | How long |" in proc.stdout


@pytest.mark.parametrize(
    ("files", "message"),
    [
        ({"wait.py": "import math\nx = 1 / 0\n"}, "wait.py:2: the skill module fails to import: "
         "ZeroDivisionError (its message is not shown"),
        ({"wait.py": WAIT.format(name="move")}, "skill name 'move' "),
        ({"notes.py": "X = 1\n"}, "defines no skill"),
        ({}, "defines no skill"),
    ],
    ids=["import_error", "name_clash", "no_skill", "empty"],
)  # fmt: skip
def test_a_bad_skill_folder_is_one_clear_error_exit_2(tmp_path, files, message, cli, monkeypatch):
    (tmp_path / "mine").mkdir()
    for name, text in files.items():
        (tmp_path / "mine" / name).write_text(text)
    monkeypatch.chdir(tmp_path)  # in-process (nothing is registered): `mine` as a user types it
    res = cli("list", "skills", "--skills", "mine")
    assert res.exit_code == 2
    assert res.exception is None and "Traceback" not in res.stderr
    assert res.stderr.startswith("error: ") and message in res.stderr, res.stderr


def test_a_scenario_names_a_missing_skill_folder_at_its_line(tmp_path):
    (tmp_path / "s.yaml").write_text(
        textwrap.dedent(
            """\
            name: s
            machine: pick_place
            skills:
              - my_skills
            """
        )
    )
    proc = _cli("validate", "s.yaml", cwd=tmp_path)
    assert proc.returncode == 2
    assert "s.yaml:4:5: skills[0]: " in proc.stderr and "no such skill file or folder" in (
        proc.stderr
    ), proc.stderr
