"""The determinism contract's numbers are measured and traced (docs/determinism.md, issue 40).

The tolerances tests allow a figure recorded on one machine come from the butterfly study
(`bench/butterfly.py`): the doc's table is the one the study's data gives, each tolerance
follows the stated rule from the measured spread, the study covered every bundled scenario,
and its repeated references were bit for bit the same (the contract on one machine).
"""

from __future__ import annotations

from pathlib import Path

from bench.butterfly import BEGIN, END, nice_ceil, table
from orchestrator.language.bundled import bundled_names

from .tolerances import study, tolerance

DOC = Path(__file__).resolve().parent.parent / "docs" / "determinism.md"


def test_the_docs_table_is_the_one_the_study_gives():
    text = DOC.read_text()
    shown = text[text.index(BEGIN) + len(BEGIN) : text.index(END)].strip()
    assert shown == table(study()), (
        "docs/determinism.md's table does not match docs/determinism.json: regenerate both "
        "with `python bench/butterfly.py --doc`"
    )


def test_each_tolerance_is_twice_the_worst_spread_rounded_up_and_at_least_a_last_digit():
    figures = study()["figures"]
    numeric = {name: f for name, f in figures.items() if "tolerance" in f}
    assert len(numeric) > 20
    for name, f in numeric.items():
        assert f["tolerance"] == max(nice_ceil(2 * f["spread"]), f["resolution"]), name
        assert f["tolerance"] >= 2 * f["spread"] and f["tolerance"] > 0, name
        assert tolerance(name) == f["tolerance"]


def test_the_study_covered_every_bundled_scenario_and_repeats_were_identical():
    data = study()
    assert sorted(data["scenarios"]) == bundled_names("scenarios")
    repeats = data["identical_repeats"]
    assert len(repeats) >= len(bundled_names("scenarios"))
    assert all(repeats.values()), [k for k, same in repeats.items() if not same]


def test_nice_ceil_rounds_up_to_1_2_5_steps():
    assert [nice_ceil(x) for x in (0, 0.004, 0.011, 0.03, 0.3, 7, 12)] == [
        0,
        0.005,
        0.02,
        0.05,
        0.5,
        10,
        20,
    ]
