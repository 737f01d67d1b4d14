"""Every name the user types that is looked up says the closest valid one when it is close
(one helper: language/diagnostics.closest), and a misspelled state declaration is named as
the typo rather than the transitions that agree with each other."""

from __future__ import annotations

from pathlib import Path

import pytest

SCENARIO = """\
name: s
machine: m.yaml
scene:
  objects:
    - {name: cube, size: [0.05, 0.05, 0.05], xy: [0.5, 0.0]}
"""


def _machine(tmp_path: Path, text: str) -> Path:
    (tmp_path / "m.yaml").write_text(text)
    (tmp_path / "s.yaml").write_text(SCENARIO)
    return tmp_path / "s.yaml"


def test_a_misspelled_skill_parameter_names_the_parameter(cli, tmp_path):
    path = _machine(tmp_path, """\
name: tiny
initial: LOOK
blackboard: {object: cube}
states:
  LOOK:
    skill: search
    with: {objcet: $object, duration_s: 1.0}
    transitions: {found: DONE, not_found: FAILED}
  DONE: {final: succeeded}
  FAILED: {final: failed}
""")  # fmt: skip
    res = cli("validate", str(path))
    assert res.exit_code == 2
    line = next(ln for ln in res.stderr.splitlines() if "objcet" in ln)
    assert "m.yaml:7:" in line and "unknown key 'objcet'" in line and "'object'?" in line


def test_a_misspelled_state_declaration_is_named_as_the_typo(cli, tmp_path):
    path = _machine(tmp_path, """\
name: tiny
initial: LOOK
blackboard: {object: cube}
states:
  LOOK:
    skill: search
    with: {object: $object}
    transitions: {found: AGAIN, not_found: FAILED}
  AGAIN:
    skill: search
    with: {object: $object}
    transitions: {found: DONE, not_found: FAILED}
  DONE: {final: succeeded}
  FAILD: {final: failed}
""")  # fmt: skip
    res = cli("validate", str(path))
    assert res.exit_code == 2
    assert "rename the declaration 'FAILD' to 'FAILED'" in res.stderr
    assert "did you mean 'FAILD'" not in res.stderr  # not: retarget both transitions


def test_a_single_misspelled_transition_still_points_at_the_declared_state(cli, tmp_path):
    path = _machine(tmp_path, """\
name: tiny
initial: LOOK
blackboard: {object: cube}
states:
  LOOK:
    skill: search
    with: {object: $object}
    transitions: {found: DONE, not_found: FAILD}
  DONE: {final: succeeded}
  FAILED: {final: failed}
""")  # fmt: skip
    res = cli("validate", str(path))
    assert res.exit_code == 2 and "did you mean 'FAILED'?" in res.stderr


@pytest.mark.parametrize(
    ("args", "wrong", "right"),
    [
        (("run", "pick_place", "--set", "place_att=pad"), "place_att", "place_at"),
        (("run", "pick_place", "--set", "physics.time_limt_s=3"), "time_limt_s", "time_limit_s"),
        (("run", "pick_place", "--break", "TRANSPRT"), "TRANSPRT", "TRANSPORT"),
        (("run", "pick_place", "--break-on", "colision"), "colision", "collision"),
        (("show", "skill", "serach"), "serach", "search"),
        (("show", "check", "object_a"), "object_a", "object_at"),
        (("show", "chek", "object_at"), "chek", "check"),
        (("show", "scenario", "pick_plce"), "pick_plce", "pick_place"),
        (("list", "skils"), "skils", "skills"),
    ],
)
def test_every_looked_up_name_says_the_closest(cli, args, wrong, right):
    res = cli(*args)
    assert res.exit_code == 2, res.stderr
    assert "Traceback" not in res.stderr
    line = next(ln for ln in res.stderr.splitlines() if wrong in ln)
    assert f"did you mean {right!r}?" in line, line
