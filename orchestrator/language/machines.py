"""Load and statically validate a machine file: its own entry point, apart from the
scenario's (`load.py`), so that validating a machine imports no scenario model
(docs/performance.md, "Start-up")."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from ..exceptions import ConfigError
from .bundled import bundled_names, resolve_file
from .diagnostics import Diagnostic
from .inputs import check_inputs
from .loading import MachineNode, load_machine_file
from .validation import validate_machine

__all__ = ["load_machine"]


def load_machine(
    ref: str, base_dir: Path | None = None, allow_paths: Sequence[Path | str] = ()
) -> MachineNode:
    """Load and statically validate a machine by path or bundled name.

    Args:
        ref: A machine file or a bundled name.
        base_dir: Directory `ref` is relative to (default: the working directory).
        allow_paths: Directories outside the machine's own tree that its includes may name.

    Raises:
        ConfigError: With every problem found, each located in its file.
    """
    path = resolve_file(ref, "machines", base_dir)
    if path is None:
        raise ConfigError(
            [
                Diagnostic(
                    ref,
                    0,
                    0,
                    "<machine>",
                    "no such machine file or bundled machine",
                    tuple(bundled_names("machines")),
                )
            ]
        )
    node, problems = load_machine_file(path, tuple(Path(a) for a in allow_paths))
    if node is not None:
        problems += validate_machine(node) + check_inputs(node)
    if problems:
        raise ConfigError(problems)
    assert node is not None
    return node
