"""Variations of a scenario: a few parameters moved from nominal, drawn by a seeded numpy
generator (same seed, same parameters -> the same variations, on any machine).

Each variation moves between 1 and `max_moved` parameters (chosen uniformly among them all)
and runs its own episode seed. A moved number is drawn uniformly over its validated range, or,
with the stated shares, put at an edge of it (`edge_share`: the one parameter at its lower or
upper bound) or every moved parameter at a corner (`corner_share`: each at a bound). A choice
takes one of its other values. What validation then refuses is drawn again (a variation is
uniform within what validation accepts): `draw_variations` takes the check as a callable.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..world.random_streams import stream
from .params import Parameter, override_texts

__all__ = ["CORNER_SHARE", "EDGE_SHARE", "MAX_MOVED", "Variation", "draw_variations"]

EDGE_SHARE = 0.15
"""Share of moved parameters put at a bound of their range."""
CORNER_SHARE = 0.10
"""Share of variations whose every moved parameter sits at a bound (a corner)."""
MAX_MOVED = 3
"""Most parameters one variation moves."""
MAX_TRIES = 50
"""Draws per variation before giving up on one validation accepts."""
SEED_SPACE = 2**31 - 1
"""Episode seeds are drawn below this."""


@dataclass(frozen=True)
class Variation:
    """One point of the explored space.

    Attributes:
        k: Its number in the exploration (0, 1, ...).
        seed: The episode seed it runs.
        values: Moved parameter path -> its value (the rest stay nominal).
        kind: `interior`, `edge` or `corner`: how it was drawn.
        refused: Draws validation refused before this one.
    """

    k: int
    seed: int
    values: dict[str, Any] = field(default_factory=dict)
    kind: str = "interior"
    refused: int = 0

    def overrides(self, params: Mapping[str, Parameter]) -> tuple[str, ...]:
        """The `--set` texts of this variation (`params`: every parameter by path)."""
        return override_texts(self.values, params)

    def to_dict(self) -> dict[str, Any]:
        return {"k": self.k, "seed": self.seed, "values": dict(self.values), "kind": self.kind,
                "refused": self.refused}  # fmt: skip


def _value(p: Parameter, rng: np.random.Generator, at_edge: bool) -> Any:
    if p.choices:
        others = [c for c in p.choices if c != p.nominal] or list(p.choices)
        return others[int(rng.integers(len(others)))]
    assert p.lo is not None and p.hi is not None
    if at_edge:
        x = p.lo if rng.random() < 0.5 else p.hi
    else:
        x = float(rng.uniform(p.lo, p.hi))
    if p.integer:
        return int(round(x))
    return round(float(x), 6)


def _draw(params: Sequence[Parameter], rng: np.random.Generator, max_moved: int,
          edge_share: float, corner_share: float) -> tuple[dict[str, Any], str]:  # fmt: skip
    n = int(rng.integers(1, min(max_moved, len(params)) + 1))
    chosen = sorted(rng.choice(len(params), size=n, replace=False).tolist())
    corner = bool(rng.random() < corner_share)
    values: dict[str, Any] = {}
    edge = False
    for i in chosen:
        at_edge = corner or bool(rng.random() < edge_share)
        edge |= at_edge and not params[i].choices
        values[params[i].path] = _value(params[i], rng, at_edge)
    return values, "corner" if corner else "edge" if edge else "interior"


def draw_variations(
    params: Sequence[Parameter],
    n: int,
    seed: int,
    accepts: Callable[[tuple[str, ...]], bool],
    max_moved: int = MAX_MOVED,
    edge_share: float = EDGE_SHARE,
    corner_share: float = CORNER_SHARE,
) -> list[Variation]:
    """`n` variations of `params`, the same for the same arguments.

    Args:
        params: The scenario's parameters (`scenario_parameters`).
        n: How many.
        seed: The exploration's seed.
        accepts: Validation: True if the scenario with these `--set` texts loads.
        max_moved: Most parameters a variation moves.
        edge_share: Share of moved parameters put at a bound.
        corner_share: Share of variations with every moved parameter at a bound.

    Returns:
        The variations; one validation refused `MAX_TRIES` times in a row is left out.
    """
    if not params:
        return []
    rng = stream(seed, "explore")
    by_path = {p.path: p for p in params}
    out: list[Variation] = []
    seeds: set[int] = set()
    for k in range(n):
        episode_seed = int(rng.integers(SEED_SPACE))
        while episode_seed in seeds:  # one seed per variation: results are keyed by it
            episode_seed = int(rng.integers(SEED_SPACE))
        seeds.add(episode_seed)
        for tries in range(MAX_TRIES):
            values, kind = _draw(params, rng, max_moved, edge_share, corner_share)
            var = Variation(k, episode_seed, values, kind, tries)
            if accepts(var.overrides(by_path)):
                out.append(var)
                break
    return out
