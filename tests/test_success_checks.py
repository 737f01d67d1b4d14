"""Success checks as plugins: the built-in `stacked` and `in_region` judged on objects placed
by hand, the stacking flow and a check of one's own built from docs/success-checks.md alone
(one seed here, ten in the slow suite), checks from a local folder and from installed
packages, listed and shown by the CLI."""

from __future__ import annotations

import json
import math
import os
import re
import subprocess
import sys
from pathlib import Path

import mujoco
import pytest
from orchestrator.robots import Controller

from orchestrator.engine.blackboard import Blackboard
from orchestrator.engine.cell import Cell
from orchestrator.engine.context import Context
from orchestrator.language.load import load_scenario
from orchestrator.success import get_check
from orchestrator.world import World

from .test_tutorial import _run, _steps

REPO = Path(__file__).resolve().parent.parent
PAGE = REPO / "docs" / "success-checks.md"


@pytest.fixture(scope="module")
def stack_ctx() -> Context:
    """The bundled stack scenario's world, seed 0, with nothing run: objects are placed by
    hand (qpos) for each case."""
    world = World.build(load_scenario("stack").scenario, seed=0)
    ctrl = Controller(world.robot, float(world.model.opt.timestep))
    return Context(Cell(world, ctrl, 0), Blackboard())


def _place(ctx: Context, name: str, pos, quat=(1.0, 0.0, 0.0, 0.0)) -> None:
    adr = ctx.world.objects[name].qpos_adr
    ctx.data.qpos[adr : adr + 7] = [*pos, *quat]
    mujoco.mj_forward(ctx.model, ctx.data)


def _judge(ctx: Context, kind: str, **params):
    cls = get_check(kind)
    check = cls(cls.Params.model_validate({"kind": kind, **params}))
    return check.evaluate(ctx), check.metrics(ctx)


def _tilted_x(deg: float) -> tuple[float, ...]:
    half = math.radians(deg) / 2
    return (math.cos(half), math.sin(half), 0.0, 0.0)


BASE = (0.5, 0.15, 0.225)
"""The base cube's centre on the table (5 cm cube, table top at z = 0.2 m) [m]."""


_UP = (1.0, 0.0, 0.0, 0.0)
_TILT = 0.025 * (math.cos(math.radians(20)) + math.sin(math.radians(20)) - 1)
"""How much higher a 5 cm cube's centre rests when tilted 20 deg about an edge [m]."""


@pytest.mark.parametrize(
    ("top", "quat", "passed", "says"),
    [
        ((0.5, 0.15, 0.275), _UP, True, "top 0.0 mm off the centre of base, gap to its top +0.0"),
        ((0.512, 0.15, 0.275), _UP, False, "top 12.0 mm off the centre of base"),
        ((0.5, 0.15, 0.295), _UP, False, "gap to its top +20.0 mm"),
        ((0.5, 0.2, 0.225), _UP, False, "50.0 mm off the centre of base, gap to its top -50.0"),
        ((0.5, 0.15, 0.275 + _TILT), _tilted_x(20.0), False, "tilted 20.0 deg: over upright_tol"),
    ],
    ids=["on", "off_centre", "hovering", "beside", "tilted"],
)
def test_stacked_measures_the_two_boxes(stack_ctx, top, quat, passed, says):
    _place(stack_ctx, "base", BASE)
    _place(stack_ctx, "top", top, quat)
    verdict, metrics = _judge(stack_ctx, "stacked", object="top", on_top_of="base")
    assert verdict.passed is passed and says in verdict.detail, verdict.detail
    dx, dy = top[0] - BASE[0], top[1] - BASE[1]
    assert metrics["xy_error_mm"] == pytest.approx(1000 * math.hypot(dx, dy), abs=1e-3)


def test_object_at_says_a_stacked_cube_is_not_on_the_table(stack_ctx):
    # the case: a good stack, judged by the table-top check, fails — stacked passes
    _place(stack_ctx, "base", BASE)
    _place(stack_ctx, "top", (0.5, 0.15, 0.275))
    verdict, _ = _judge(stack_ctx, "object_at", object="top", target=[0.5, 0.15, 0.2])
    assert not verdict.passed and "not resting on the table (50 mm above it)" in verdict.detail


@pytest.mark.parametrize(
    ("whole", "passed", "says"),
    [(False, True, "the centre of base inside the box"), (True, False, "5.0 mm out of the box")],
)
def test_in_region_judges_the_centre_or_every_corner(stack_ctx, whole, passed, says):
    _place(stack_ctx, "base", BASE)
    box = {"min": [0.48, 0.12, 0.2], "max": [0.54, 0.18, 0.26]}  # x: 5 mm short of the cube
    verdict, metrics = _judge(stack_ctx, "in_region", object="base", whole=whole, **box)
    assert verdict.passed is passed and says in verdict.detail, verdict.detail
    assert metrics["outside_mm"] == pytest.approx(0.0 if not whole else 5.0, abs=1e-6)
    _place(stack_ctx, "base", (0.5, 0.25, 0.225))  # pushed 10 cm along y: out by 70 mm
    verdict, metrics = _judge(stack_ctx, "in_region", object="base", **box)
    assert not verdict.passed and "70.0 mm out of the box" in verdict.detail
    assert "along y" in verdict.detail and metrics["outside_mm"] == pytest.approx(70.0)


def _write_page(folder: Path) -> list[str]:
    """The page's files written into `folder`; its commands, in order."""
    commands = []
    for name, body in _steps(PAGE, None):
        if name == "run":
            commands += [ln for ln in body.splitlines() if ln.strip() and not ln.startswith("#")]
            continue
        (folder / name).parent.mkdir(parents=True, exist_ok=True)
        (folder / name).write_text(body)
    return commands


def test_the_pages_flow_is_the_bundled_stack_machine():
    flow = dict(_steps(PAGE, None))["stack_flow.yaml"]
    bundled = (REPO / "machines" / "stack.yaml").read_text().splitlines(keepends=True)
    assert flow == "".join(ln for ln in bundled if "yaml-language-server" not in ln)


@pytest.fixture(scope="module")
def page_folder(tmp_path_factory) -> Path:
    """The page's files, and the same flow without turning to the base's yaw (run in this
    process: the page's check is registered once, from this folder)."""
    folder = tmp_path_factory.mktemp("page")
    _write_page(folder)
    flow = (folder / "stack_flow.yaml").read_text()
    (folder / "unturned_flow.yaml").write_text(flow.replace("align_yaw: true", "align_yaw: false"))
    cell = (folder / "stack_cell.yaml").read_text()
    cell = cell.replace("machine: stack_flow.yaml", "machine: unturned_flow.yaml")
    (folder / "unturned_cell.yaml").write_text(cell)
    return folder


def test_the_pages_stack_and_check_are_found_validated_and_judge_a_run(cli, page_folder):
    res = cli("validate", str(page_folder / "stack_cell.yaml"))  # imports nothing the file names
    assert res.exit_code == 2 and "pass --skills" in res.stderr, res.stderr
    res = cli(
        "validate", str(page_folder / "stack_cell.yaml"), "--skills", str(page_folder / "my_checks")
    )
    assert res.exit_code == 0, res.stderr
    res = cli("show", "check", "aligned", "--skills", str(page_folder / "my_checks"))
    assert res.exit_code == 0 and "| `yaw_tol_deg` | float | deg | `5.0` | > 0, ≤ 180 |" in (
        res.stdout
    )
    res = cli("run", str(page_folder / "stack_cell.yaml"), "--seed", "1", "--json")
    assert res.exit_code == 0, res.stderr
    result = res.json
    checks = ("stacked", "base_in_place", "turned_alike", "let_go")
    assert result["success"] == dict.fromkeys(checks, True)
    detail = result["success_detail"]["turned_alike"]
    assert re.fullmatch(r"top turned [0-9.]+ deg from base \(yaw_tol_deg 5\)", detail), detail
    assert 0.0 <= result["metrics"]["turned_alike_yaw_error_deg"] <= 5.0
    assert result["metrics"]["stacked_xy_error_mm"] <= 10.0


def test_the_pages_check_fails_a_flow_that_does_not_turn_the_cube(cli, page_folder):
    # the same flow without turning to the base's yaw: the cubes stack, but not alike
    res = cli("run", str(page_folder / "unturned_cell.yaml"), "--seed", "1", "--json")
    assert res.exit_code == 1, res.stderr
    result = res.json
    assert result["outcome"] == "failed" and result["success"]["turned_alike"] is False
    assert result["success"]["stacked"] is True
    assert result["metrics"]["turned_alike_yaw_error_deg"] > 5.0


@pytest.mark.slow
def test_the_stacking_flow_and_check_from_the_page_pass_on_10_seeds(tmp_path):
    commands = _write_page(tmp_path)
    assert commands[-1].startswith("orchestrator batch stack_cell.yaml -n 10")
    for line in commands:
        proc = _run(line, tmp_path)
        assert proc.returncode == 0 and "Traceback" not in proc.stderr, f"{line}\n{proc.stderr}"
    summary = json.loads((tmp_path / "runs" / "stack" / "summary.json").read_text())
    assert (summary["episodes"], summary["succeeded"]) == (10, 10), summary["failing_seeds"]
    lines = [json.loads(ln) for ln in (tmp_path / "runs" / "stack" / "results.jsonl").open()]
    assert sorted(ln["seed"] for ln in lines) == list(range(10))
    for ln in lines:
        assert all(ln["success"].values()) and len(ln["success"]) == 4, ln["success_detail"]


CHECK = '''
from typing import ClassVar
from orchestrator.success import CheckParams, SuccessCheck, Verdict


class Always(SuccessCheck):
    """Passes, always."""

    kind: ClassVar[str] = "{kind}"
    Params: ClassVar[type[CheckParams]] = CheckParams

    def evaluate(self, ctx):
        return Verdict(True, "always")
'''


def test_a_folder_of_checks_alone_is_loaded_and_one_of_neither_is_refused(cli, tmp_path):
    (tmp_path / "checks").mkdir()
    (tmp_path / "checks" / "always.py").write_text(CHECK.format(kind="always_local"))
    res = cli("list", "checks", "--skills", str(tmp_path / "checks"))
    assert res.exit_code == 0, res.stderr
    assert "always_local" in res.stdout and str(tmp_path / "checks" / "always.py") in res.stdout
    (tmp_path / "empty").mkdir()
    (tmp_path / "empty" / "nothing.py").write_text("X = 1\n")
    res = cli("list", "checks", "--skills", str(tmp_path / "empty"))
    assert res.exit_code == 2
    assert "defines no skill (a subclass of orchestrator.skills.Skill with a `name`) and no " in (
        res.stderr
    )


def test_a_check_may_not_take_a_bundled_kind(cli, tmp_path):
    (tmp_path / "mine.py").write_text(CHECK.format(kind="stacked"))
    res = cli("list", "checks", "--skills", str(tmp_path / "mine.py"))
    assert res.exit_code == 2
    assert "success check kind 'stacked' (" in res.stderr and "is already taken by " in res.stderr


def test_installed_checks_come_through_entry_points_and_a_broken_one_is_a_warning(tmp_path):
    site = tmp_path / "site"
    info = site / "fakechecks-0.1.dist-info"
    info.mkdir(parents=True)
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: fakechecks\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text(
        "[orchestrator.success_checks]\n"
        "always_plugin = fakechecks_good:Always\n"
        "broken = fakechecks_broken:Always\n"
    )
    (site / "fakechecks_good.py").write_text(CHECK.format(kind="always_plugin"))
    (site / "fakechecks_broken.py").write_text("import robot_sdk_that_is_not_installed\n")
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(site), env.get("PYTHONPATH")]))
    proc = subprocess.run(
        [sys.executable, "-m", "orchestrator.cli", "list", "checks"],
        capture_output=True,
        text=True,
        env=env,
        timeout=300,
        check=False,
    )
    assert proc.returncode == 0, proc.stderr
    assert "always_plugin" in proc.stdout and "(plugin fakechecks_good)" in proc.stdout
    (warning,) = proc.stderr.strip().splitlines()
    assert warning.startswith(
        "warning: plugin success check 'broken' (fakechecks_broken:Always, from fakechecks) "
        "failed to import and is skipped: ModuleNotFoundError"
    )
