"""The episode's random streams: one table, distinct tags, no generator made outside it."""

from __future__ import annotations

import ast
from pathlib import Path

import numpy as np
import pytest

from orchestrator.world.random_streams import STREAMS, stream

REPO = Path(__file__).resolve().parent.parent
TABLE = REPO / "orchestrator" / "world" / "random_streams.py"
_MAKERS = {"default_rng", "Generator", "RandomState", "SeedSequence", "PCG64", "seed"}


def test_every_stream_has_its_own_nonzero_tag() -> None:
    tags = list(STREAMS.values())
    assert len(set(tags)) == len(tags), {t: [n for n in STREAMS if STREAMS[n] == t] for t in tags}
    assert all(isinstance(t, int) and 0 < t < 2**32 for t in tags)


def test_streams_of_one_seed_draw_different_numbers() -> None:
    for seed in (0, 1, 7, 12345):
        firsts = {name: stream(seed, name).integers(2**63) for name in STREAMS}
        assert len(set(firsts.values())) == len(firsts)


def test_a_stream_is_the_same_for_the_same_seed_and_another_for_another() -> None:
    a, b, c = (stream(s, "object_poses").random(4) for s in (3, 3, 4))
    assert np.array_equal(a, b) and not np.array_equal(a, c)
    assert not np.array_equal(stream(3, "conveyor_feed", 0).random(4),
                              stream(3, "conveyor_feed", 1).random(4))  # fmt: skip


def test_an_unknown_stream_is_refused() -> None:
    with pytest.raises(KeyError):
        stream(0, "no_such_stream")


def _generator_calls(path: Path) -> list[int]:
    lines = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Call):
            f = node.func
            name = f.attr if isinstance(f, ast.Attribute) else getattr(f, "id", None)
            base = f.value if isinstance(f, ast.Attribute) else None
            on_random = isinstance(base, ast.Attribute) and base.attr == "random"
            if name in _MAKERS and (on_random or name == "default_rng"):
                lines.append(node.lineno)
    return lines


def test_no_module_makes_a_generator_outside_the_table() -> None:
    found = {}
    for root in ("orchestrator", "skills", "robots"):
        for path in (REPO / root).rglob("*.py"):
            if path != TABLE and (lines := _generator_calls(path)):
                found[str(path.relative_to(REPO))] = lines
    assert not found, f"random generators made outside world/random_streams.py: {found}"
    assert _generator_calls(TABLE), "the scan finds the table's own default_rng call"
