"""The README's `run --json` example is the real run's output (wall time aside)."""

from __future__ import annotations

import json
import math
from typing import Any

from docs.readme_json import COMMAND, SHOWN_METRICS, shown

FIX = "the README's JSON example is out of date: regenerate it with `python docs/readme_json.py`"


def _decimals(x: float) -> int:
    text = repr(x)
    return len(text.split(".")[1]) if "." in text and "e" not in text else 6


def _same(shown_value: Any, real: Any, where: str) -> None:
    """A number matches to the precision it is shown with; anything else exactly."""
    if isinstance(shown_value, float) and isinstance(real, float):
        tol = 0.5 * 10 ** -_decimals(shown_value) + 1e-12
        if abs(real) < 0.01:  # shown to 2 significant digits
            tol = max(tol, 0.05 * abs(real))
        assert math.isclose(shown_value, real, abs_tol=tol), (
            f"{where}: {shown_value} != {real}; {FIX}"
        )
    else:
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
            assert value == [real[key][0], "..."], f"transitions; {FIX}"
        elif key == "metrics":
            assert list(value) == [k for k in SHOWN_METRICS if k in real[key]], FIX
            for name, figure in value.items():
                _same(figure, real[key][name], f"metrics.{name}")
        else:
            _same(value, real[key], key)
