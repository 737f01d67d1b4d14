"""The guard node and the abort state, joined to nothing else, go into room the rest of the
machine graph leaves free (graph_apart.py): inside the drawing where a spot keeps clear of
every box and arrow, else beside it, never on anything."""

from __future__ import annotations

from orchestrator.recording.graph_apart import PAIR_GAP, apart_pairs, free_spot
from orchestrator.recording.graph_layout import Level

PAIR = ((80.0, 26.0), (90.0, 26.0))
"""`guard fires` over `SAFE_STOP` [px]."""
HEIGHT = 26.0 + PAIR_GAP + 26.0


def _zoom_in(panel: tuple[float, float]):
    """The zoom a drawing is shown at in a panel of `panel` (w, h) [px], at most 1."""
    return lambda b: min(1.0, panel[0] / max(b[2] - b[0], 1.0), panel[1] / max(b[3] - b[1], 1.0))


def _clear(spot, boxes, lines=()):
    x, y = spot
    w = max(PAIR[0][0], PAIR[1][0])
    for x0, y0, x1, y1 in boxes:
        if x < x1 and x0 < x + w and y < y1 and y0 < y + HEIGHT:
            return False
    for line in lines:
        for px, py in line:
            if x <= px <= x + w and y <= py <= y + HEIGHT:
                return False
    return True


def test_the_pair_goes_into_a_hole_in_the_drawing_rather_than_widen_it():
    # a 600 x 400 drawing: two columns of states, free room between x 200 and 400
    boxes = [(0, 0, 200, 400), (400, 0, 600, 400)]
    spot = free_spot(PAIR, boxes, [], _zoom_in((600, 400)))
    assert _clear(spot, boxes)
    x, y = spot
    assert 200 < x and x + 90 < 400 and y == 0  # in the hole, at its top


def test_an_arrow_through_the_hole_keeps_the_pair_off_it():
    boxes = [(0, 0, 200, 400), (400, 0, 600, 400)]
    arrow = [[(300.0, 0.0), (300.0, 200.0)]]  # down the hole's middle, its upper half
    spot = free_spot(PAIR, boxes, arrow, _zoom_in((600, 400)))
    assert _clear(spot, boxes, arrow)
    assert spot[1] > 200  # below the arrow's end, still in the hole
    assert 200 < spot[0] and spot[0] + 90 < 400


def test_a_full_drawing_gets_the_pair_beside_it_where_the_zoom_suffers_least():
    boxes = [(0, 0, 600, 400)]
    # a panel that is wide for the drawing: beside it, at its top, costs no zoom
    spot = free_spot(PAIR, boxes, [], _zoom_in((2000, 400)))
    assert _clear(spot, boxes) and spot[1] == 0 and spot[0] >= 600
    # a panel that is tall for the drawing: below it
    spot = free_spot(PAIR, boxes, [], _zoom_in((600, 2000)))
    assert _clear(spot, boxes) and spot[1] >= 400


def test_only_a_pair_joined_to_nothing_else_is_laid_out_apart():
    top = Level(["A", "B", "END", ":guard", "STOP"], [("A", "B"), ("B", "END")], "A")
    edges = {("A", "B"): None, ("B", "END"): None, (":guard", "STOP"): None}
    assert apart_pairs(top, edges) == [(":guard", "STOP")]
    # the abort state also reached by a transition: it stays in the flow
    assert apart_pairs(top, {**edges, ("B", "STOP"): "lost"}) == []
    # an arrow with a label is not one to put aside
    assert apart_pairs(top, {**edges, (":guard", "STOP"): "fires"}) == []


def test_with_frames_the_pair_stays_at_the_top():
    # the drawing's top row is taken, a hole lower down: Rerun writes the graph's caption
    # above its topmost state, which must then be above the frames' captions
    boxes = [(0, 0, 600, 100), (0, 100, 200, 400), (400, 100, 600, 400)]
    assert free_spot(PAIR, boxes, [], _zoom_in((600, 2000)))[1] > 100  # into the hole
    spot = free_spot(PAIR, boxes, [], _zoom_in((600, 2000)), at_top=True)
    assert _clear(spot, boxes) and spot[1] == 0
