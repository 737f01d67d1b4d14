"""The unit cells of the generated references (docs/skills.md, docs/scenario-reference.md)
say what each parameter's description and name say: a unit stated mid-sentence (`[m/s]
(capped by ...)`) is the unit, a list (`[0, 0, -1]`) is not one, a name is unitless."""

from __future__ import annotations

import re

import pytest
from orchestrator.skills import all_skills

from orchestrator.guards import GUARDS
from orchestrator.language.reference import _INNER_UNIT, _SUFFIX_UNITS, param_rows
from orchestrator.language.scenario import Scenario
from orchestrator.success import CHECKS


def _models():
    for name, cls in sorted(all_skills().items()):
        yield f"skill {name}", cls.Params
    for kind, cls in sorted(CHECKS.items()):
        yield f"check {kind}", cls.Params
    for name, cls in sorted(GUARDS.items()):
        yield f"guard {name}", cls.Params
    yield "scenario", Scenario


def _rows():
    seen = set()
    todo = list(_models())
    while todo:
        owner, model = todo.pop()
        if model in seen:
            continue
        seen.add(model)
        for row in param_rows(model):
            yield owner, row
            if row.model is not None:
                todo.append((f"{owner}.{row.name}", row.model))


ROWS = list(_rows())


def test_the_rows_are_many():
    assert len(ROWS) > 200


@pytest.mark.parametrize(("owner", "row"), ROWS, ids=[f"{o}:{r.name}" for o, r in ROWS])
def test_a_unit_cell_says_what_the_parameter_says(owner, row):
    stated = [m.group(1) for m in _INNER_UNIT.finditer(row.description)]
    assert not re.search(r"\d\s*,", row.unit), row.unit  # a list of numbers is not a unit
    if row.kind == "str":
        assert row.unit == "", "a name has no unit"
    elif stated and row.kind != "any":  # several forms (a name, a pose, `[x, y, z]` [m])
        assert all(u in row.unit for u in stated), (row.unit, row.description)
    if row.unit and row.kind != "str":
        suffix = next((u for s, u in _SUFFIX_UNITS if row.name.endswith(s)), None)
        if suffix in ("s", "m", "N") and row.unit != suffix:
            # the name's unit, compounded (`_rad_s` -> rad/s, `_n_per_m` -> N/m), not another
            assert row.unit.endswith(suffix) or "/" + suffix in row.unit, (row.name, row.unit)
