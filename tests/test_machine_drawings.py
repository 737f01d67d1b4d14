"""The machines drawn in the docs are drawn from the machines as they are now.

docs/make_images.py keeps, beside each Graphviz drawing, the SHA-256 of the DOT source it was
drawn from (`docs/images/NAME.dot.sha256`). A change to a bundled machine changes its DOT
source, and this test then fails until the drawing is made again.
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import pytest

from orchestrator.language.graph import to_dot
from orchestrator.language.load import load_machine

ROOT = Path(__file__).resolve().parents[1]


def _make_images():
    spec = importlib.util.spec_from_file_location("make_images", ROOT / "docs" / "make_images.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules.setdefault("make_images", module)
    spec.loader.exec_module(module)
    return module


MAKE_IMAGES = _make_images()
DRAWINGS = [s for s in MAKE_IMAGES.SCENES if isinstance(s, MAKE_IMAGES.MachineDrawing)]


def test_the_docs_draw_at_least_the_machines_the_readme_shows():
    assert {d.name for d in DRAWINGS} >= {"machine_pick_place", "machine_surgical"}


@pytest.mark.parametrize("drawing", DRAWINGS, ids=lambda d: d.name)
def test_a_drawing_is_not_older_than_its_machine(drawing):
    png = MAKE_IMAGES.IMAGES / f"{drawing.name}.png"
    kept = MAKE_IMAGES.digest_file(drawing.name)
    assert png.is_file(), f"{png} is missing: python docs/make_images.py {drawing.name}"
    assert kept.is_file(), f"{kept} is missing: python docs/make_images.py {drawing.name}"
    now = MAKE_IMAGES.dot_digest(to_dot(load_machine(drawing.machine)))
    assert kept.read_text().strip() == now, (
        f"{png.name} was drawn from another version of machine {drawing.machine!r}: "
        f"draw it again with `python docs/make_images.py {drawing.name}`"
    )
