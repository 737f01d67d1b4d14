"""bench/stock_mink_loop.py: the stock mink + MuJoCo loop issue 43's speed is measured against
(bench/speed_paired.py) must do the task on pick_place's plant, or its speed means nothing."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import pytest

BENCH = Path(__file__).resolve().parent.parent / "bench" / "stock_mink_loop.py"


@pytest.fixture(scope="module")
def stock():
    spec = importlib.util.spec_from_file_location("bench_stock_mink_loop", BENCH)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses look their module up
    spec.loader.exec_module(module)
    yield module
    del sys.modules[spec.name]


def test_stock_loop_places_the_cube(stock, pick_place) -> None:
    loop = stock.StockLoop(pick_place.scenario, 0)
    cycle, placed = loop.run()
    assert placed  # on the pad within 1 cm, upright
    assert cycle is not None and cycle < 6.0  # every line reached: no settle timeout
    # released and clear: the fingers open wider than the cube
    opening = float(loop.d.qpos[loop.fingers].sum())
    assert opening > 2.0 * float(max(loop.w.objects["cube"].half_size))
