"""Modules stay small enough to read: none of the package's modules is over `MAX_LINES` lines
unless its docstring says why (the words "over 600 lines" and the reason)."""

from __future__ import annotations

import ast
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
ROOTS = (REPO / "orchestrator", REPO / "skills", REPO / "robots")
MAX_LINES = 600


def _too_long(root: Path) -> list[str]:
    """Modules under `root` over `MAX_LINES` lines whose docstring does not say why."""
    found = []
    for path in sorted(root.rglob("*.py")):
        text = path.read_text()
        n = len(text.splitlines())
        if n <= MAX_LINES:
            continue
        doc = ast.get_docstring(ast.parse(text, str(path))) or ""
        if f"over {MAX_LINES} lines" not in " ".join(doc.lower().split()):
            found.append(f"{root.name}/{path.relative_to(root)}: {n} lines")
    return found


def test_no_module_is_over_600_lines_without_a_reason_at_its_top():
    long = [m for root in ROOTS for m in _too_long(root)]
    assert long == [], (
        f"modules over {MAX_LINES} lines: split them by what they hold, or say at their top "
        f"why not ('over {MAX_LINES} lines because ...'): {long}"
    )


def test_the_size_check_sees_a_long_module_and_its_reason(tmp_path: Path):
    body = "x = 1\n" * MAX_LINES
    (tmp_path / "long.py").write_text('"""A module."""\n' + body)
    (tmp_path / "said.py").write_text(
        '"""A table of constants: over 600 lines because\nit is generated."""\n' + body
    )
    (tmp_path / "short.py").write_text('"""Short."""\nx = 1\n')
    assert _too_long(tmp_path) == [f"{tmp_path.name}/long.py: {MAX_LINES + 1} lines"]
