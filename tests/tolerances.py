"""How far a figure recorded on one machine may be from the same run on another (issue 40).

A run is bit for bit the same on one machine and install; on another CPU or with other library
versions a contact-rich run rounds differently and its figures move. By how much was measured,
not guessed: `bench/butterfly.py` nudges the initial state of every bundled scenario in its
last bits and records each figure's spread; the tolerance of a figure is twice its worst
spread, rounded up, and at least one unit of its last printed digit (docs/determinism.md, whose
table and `docs/determinism.json` the study writes). A test that compares a run with numbers
recorded on one machine (the README's JSON example, a doc's figures) allows this much.
"""

from __future__ import annotations

import functools
import json
import re
from pathlib import Path
from typing import Any

STUDY = Path(__file__).resolve().parent.parent / "docs" / "determinism.json"
"""The butterfly study's summary (written by `python bench/butterfly.py --doc`)."""


@functools.cache
def study() -> dict[str, Any]:
    return json.loads(STUDY.read_text())


def tolerance(figure: str) -> float:
    """The tolerance of `figure`, named as the study names it (`metrics.cycle_time`,
    `sim_time`, `success_detail.cube_on_target#0`; a list item as `metrics.tcp_target_m[1]`).

    Raises:
        KeyError: The study has no such numeric figure (run it again if the product prints a
            new one: `python bench/butterfly.py --doc`).
    """
    name = re.sub(r"\[\d+\]$", "[i]", figure)
    entry = study()["figures"].get(name)
    if entry is None or "tolerance" not in entry:
        raise KeyError(
            f"{figure}: no numeric figure of that name in {STUDY.name}; run "
            "`python bench/butterfly.py --doc` to measure it"
        )
    return float(entry["tolerance"])
