"""The README's `run --json` example is the real run's output (wall time aside).

The example was recorded on one machine; on another CPU or with other library versions the
contact-rich run rounds differently and its figures move in their last digits (0.198 mm of
placement error in the README, 0.204 mm on another x86-64 family). So each number is compared
within the tolerance the butterfly study measured for that figure (tests/tolerances.py,
docs/determinism.md), never to its last digit; the outcome, the states, the checks' verdicts
and every word are compared exactly.
"""

from __future__ import annotations

import json
import math
import re
from typing import Any

from docs.readme_json import COMMAND, SHOWN_METRICS, shown

from .tolerances import tolerance

FIX = "the README's JSON example is out of date: regenerate it with `python docs/readme_json.py`"
_NUMBER = re.compile(r"-?\d+(?:\.\d+)?(?:e[-+]?\d+)?")
"""A number in a text (as the butterfly study reads `success_detail`)."""


def _decimals(x: float) -> int:
    text = repr(x)
    return len(text.split(".")[1]) if "." in text and "e" not in text else 6


def _close(shown_value: float, real: float, figure: str, where: str) -> None:
    """`shown_value` (rounded for the README) is `real` within the rounding and the figure's
    measured tolerance."""
    rounding = 0.5 * 10 ** -_decimals(shown_value)
    if 0 < abs(real) < 0.01:  # shown to 2 significant digits
        rounding = max(rounding, 0.05 * abs(real))
    allowed = rounding + tolerance(figure) + 1e-12
    assert math.isclose(shown_value, real, abs_tol=allowed), (
        f"{where}: {shown_value} != {real} (allowed ±{allowed:g}: the rounding and the "
        f"tolerance of {figure} in docs/determinism.md); {FIX}"
    )


def _same_text(shown_text: str, real: str, key: str) -> None:
    """The words exactly, each number within its figure's tolerance."""
    assert _NUMBER.sub("#", shown_text) == _NUMBER.sub("#", real), (
        f"success_detail.{key}: {shown_text!r} != {real!r}; {FIX}"
    )
    pairs = zip(_NUMBER.findall(shown_text), _NUMBER.findall(real), strict=True)
    for i, (a, b) in enumerate(pairs):
        _close(float(a), float(b), f"success_detail.{key}#{i}", f"success_detail.{key}")


def _same(shown_value: Any, real: Any, where: str) -> None:
    assert shown_value == real, f"{where}: {shown_value!r} != {real!r}; {FIX}"


def test_the_readme_json_example_is_the_real_run(cli):
    res = cli(*COMMAND[1:])
    assert res.exit_code == 0, res.stderr
    real = json.loads(res.stdout)
    example = json.loads(shown())
    assert list(example) == list(real), f"keys differ; {FIX}"
    for key, value in example.items():
        if key == "wall_time":
            continue
        if key == "transitions":
            first, real_first = value[0], real[key][0]
            assert value[1:] == ["..."], f"transitions; {FIX}"
            _same({**first, "t": None}, {**real_first, "t": None}, "transitions[0]")
            _close(first["t"], real_first["t"], "transitions[0].t", "transitions[0].t")
        elif key == "metrics":
            assert list(value) == [k for k in SHOWN_METRICS if k in real[key]], FIX
            for name, figure in value.items():
                _close(figure, real[key][name], f"metrics.{name}", f"metrics.{name}")
        elif key == "success_detail":
            assert list(value) == list(real[key]), f"success_detail; {FIX}"
            for check, text in value.items():
                _same_text(text, real[key][check], check)
        elif key == "sim_time":
            _close(value, real[key], "sim_time", key)
        elif key == "invariants":  # what held exactly; how close each limit came, in tolerance
            _same({**value, "worst": None}, {**real[key], "worst": None}, key)
            assert list(value["worst"]) == list(real[key]["worst"]), f"invariants; {FIX}"
            for name, figure in value["worst"].items():
                where = f"invariants.worst.{name}"
                _close(figure, real[key]["worst"][name], where, where)
        else:
            _same(value, real[key], key)


def test_the_other_cpus_figure_lies_within_the_tolerance():
    """The divergence the issue saw on another CPU family (0.198 -> 0.204 mm) is inside the
    measured tolerance: the study's nudges stand for another machine's rounding."""
    assert abs(0.204 - 0.198) <= tolerance("metrics.cube_on_target_xy_error_mm")
