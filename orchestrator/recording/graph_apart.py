"""A pair of states no transition joins to the rest of the graph, put in room the rest leaves.

The guard node and the abort state it leads to (`guard fires` -> `SAFE_STOP`) are joined to
nothing else in most machines. Laid out by `dot` with the rest, they take a column of their
own beside it (~110 px of width, more than a 1280x720 panel has to spare); laid out apart,
they go to the topmost, then rightmost, spot inside the drawing that no box, frame, caption
or arrow takes (one above the other, the arrow between them), or, when there is none, beside
the drawing at its top, where `dot` put them. Nothing here knows about Rerun.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from .graph_layout import CAPTION_H, Level

__all__ = ["PAIR_GAP", "apart_pairs", "caption_box", "free_spot", "without"]

_CELL = 4.0
"""Side of a cell of the grid the free room is looked for on [px]."""
_CLEAR = 7.0
"""Least room between the pair and anything else [px] (`dot`'s gap between neighbours)."""
PAIR_GAP = 21.0
"""Room between the two states of a pair, for the arrow between them and its head [px]."""

Rect = tuple[float, float, float, float]
Point = tuple[float, float]


def apart_pairs(top: Level, edges: dict[tuple[str, str], str | None]) -> list[tuple[str, str]]:
    """The top-level pairs (a, b) joined to nothing else: a leads to b alone and nothing leads
    to a, nothing but a leads to b and b leads nowhere, the arrow carries no label, neither
    runs a nested machine nor starts the machine."""
    into: dict[str, list[str]] = {}
    out: dict[str, list[str]] = {}
    for src, dst in edges:
        out.setdefault(src, []).append(dst)
        into.setdefault(dst, []).append(src)
    pairs = []
    for a in top.nodes:
        if a == top.initial or a in top.nested or into.get(a) or len(out.get(a, [])) != 1:
            continue
        b = out[a][0]
        if (
            b != a and b in top.nodes and b != top.initial and b not in top.nested
            and into.get(b) == [a] and not out.get(b) and edges[(a, b)] is None
        ):  # fmt: skip
            pairs.append((a, b))
    return pairs


def without(level: Level, nodes: set[str]) -> Level:
    """The top `level` without `nodes` (top-level states) and the transitions touching them."""
    return Level(
        [n for n in level.nodes if n not in nodes],
        [(a, b) for a, b in level.edges if a not in nodes and b not in nodes],
        level.initial,
        level.nested,
        list(level.exits),
    )


def free_spot(
    pair: tuple[tuple[float, float], tuple[float, float]],
    boxes: list[Rect],
    lines: list[list[Point]],
    zoom: Callable[[Rect], float],
    at_top: bool = False,
) -> tuple[float, float]:
    """Where the pair goes: the top-left corner (x, y) [px] of the box it takes, the upper
    state's `pair[0]` (w, h) centred over the lower's `pair[1]`, `PAIR_GAP` apart.

    Args:
        pair: The sizes (w, h) [px] of the upper and the lower state.
        boxes: What the drawing takes: states, labels, frames with their captions [px].
        lines: The arrows as polylines [px].
        zoom: The zoom a drawing within bounds (x0, y0, x1, y1) [px] is shown at.
        at_top: Only spots at the drawing's top (with frames: Rerun writes the graph's
            caption above its topmost state, and it must stay above the frames' captions).

    Returns:
        Of the spots that keep `_CLEAR` from every box and arrow, inside the drawing or
        beside it (left, right, below), one where the drawing is shown at the largest zoom;
        of those, one at the drawing's top if there is one; then one that grows the drawing
        the least; of those, the topmost, then rightmost.
    """
    (wa, ha), (wb, hb) = pair
    w, h = max(wa, wb), ha + PAIR_GAP + hb
    hh, ww = math.ceil(h / _CELL) + 1, math.ceil(w / _CELL) + 1
    k = math.ceil(_CLEAR / _CELL)
    # the grid: the drawing, and room for the pair and its clearance left, right and below
    bx0 = min(b[0] for b in boxes)
    by0 = min(b[1] for b in boxes)
    bx1 = max(b[2] for b in boxes)
    by1 = max(b[3] for b in boxes)
    x0, y0 = bx0 - (ww + 2 * k + 1) * _CELL, by0
    cols = math.ceil((bx1 - x0) / _CELL) + ww + 2 * k + 2
    rows = math.ceil((by1 - y0) / _CELL) + hh + 2 * k + 2
    taken = np.zeros((rows, cols), dtype=np.int64)
    for rx0, ry0, rx1, ry1 in boxes:
        c0, r0 = _cell(rx0 - x0, cols), _cell(ry0 - y0, rows)
        c1, r1 = _cell(rx1 - x0, cols), _cell(ry1 - y0, rows)
        taken[r0 : r1 + 1, c0 : c1 + 1] = 1
    for line in lines:
        points = np.asarray(line, dtype=float)
        if len(points) < 2:
            continue
        along = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(points, axis=0).T))])
        at = np.arange(0.0, along[-1] + _CELL / 2, _CELL / 2)
        xs, ys = np.interp(at, along, points[:, 0]), np.interp(at, along, points[:, 1])
        cs = np.clip((xs - x0) // _CELL, 0, cols - 1).astype(int)
        rs = np.clip((ys - y0) // _CELL, 0, rows - 1).astype(int)
        taken[rs, cs] = 1
    # the cells taken in the pair's window (top-left cell r, c) grown by the clearance on
    # every side (above the grid's top there is nothing)
    grown = np.pad(taken, ((k, 0), (0, 0)))
    summed = np.zeros((rows + k + 1, cols + 1), dtype=np.int64)
    summed[1:, 1:] = grown.cumsum(0).cumsum(1)
    gh, gw = hh + 2 * k, ww + 2 * k
    n_r, n_c = rows + k - gh + 1, cols - gw + 1
    inside = (
        summed[gh : gh + n_r, gw : gw + n_c] - summed[:n_r, gw : gw + n_c]
        - summed[gh : gh + n_r, :n_c] + summed[:n_r, :n_c]
    )  # fmt: skip
    tops = y0 + np.arange(n_r) * _CELL  # the pair's top with the window at row r
    lefts = x0 + (np.arange(n_c) + k) * _CELL
    # the zoom is the lesser of a width's and a height's: each row's and column's apart
    by_row = np.array([zoom((bx0, by0, bx0, max(by1, t + h))) for t in tops])
    by_col = np.array([zoom((min(bx0, x), by0, max(bx1, x + w), by0)) for x in lefts])
    score = np.minimum(by_row[:, None], by_col[None, :])
    score[inside > 0] = -1.0
    if at_top:
        score[1:] = -1.0
    heights = np.maximum(by1, tops + h) - by0
    widths = np.maximum(bx1, lefts + w) - np.minimum(bx0, lefts)
    area = heights[:, None] * widths[None, :]
    best = score >= score.max() - 1e-9
    if best[0].any():
        best[1:] = False
    best &= area <= area[best].min() + 1e-6  # of those, the drawing grown the least
    r, c = min(zip(*np.nonzero(best), strict=True), key=lambda rc: (rc[0], -rc[1]))
    return float(lefts[c]), float(tops[r])


def _cell(offset: float, count: int) -> int:
    return min(max(int(offset // _CELL), 0), count - 1)


def caption_box(frame: Rect, caption_w: float) -> Rect:
    """A frame (x0, y0, x1, y1) with the caption written above it [px]."""
    x0, y0, x1, y1 = frame
    return x0, y0 - CAPTION_H, max(x1, x0 + caption_w), y1
