"""What a snapshot must be resumed with: the same code and the same libraries.

A resumed run is bit-identical to the uninterrupted one only on the code that wrote the
snapshot: another MuJoCo steps differently, another version of a skill plans differently. So
a snapshot records the versions below and `run --from` refuses one whose versions differ from
its own, naming each difference.
"""

from __future__ import annotations

import functools
import hashlib
import platform
import sys
from importlib import metadata
from pathlib import Path

from ...skills.plugins import LOCAL_PREFIX
from ...world.native import native

__all__ = ["FORMAT", "differences", "local_code", "local_files", "versions"]

FORMAT = 2
"""The snapshot file format; a file of another format is refused (1: a pickle, gone)."""

_DISTRIBUTIONS = (
    "embodied-orchestrator",
    "mujoco",
    "numpy",
    "pin",
    "mink",
    "daqp",
    "ruckig",
    "transitions",
    "pydantic",
    "scipy",
    "opencv-python-headless",
)
"""The libraries a run's numbers depend on."""


@functools.cache
def _version(dist: str) -> str:  # installed once per process: read once (a write reads 11)
    try:
        return metadata.version(dist)
    except metadata.PackageNotFoundError:
        return "absent"


@functools.cache
def _package_code() -> str:
    """SHA-256 of the framework's own code: every `.py` file of `orchestrator` (with the skills
    and robots installed into it) and the compiled module, by path."""
    h = hashlib.sha256()
    roots = {Path(__file__).resolve().parents[2]}  # the orchestrator package
    for sub in ("skills", "robots"):
        module = sys.modules.get(f"orchestrator.{sub}")
        if module is not None and module.__file__:
            roots.add(Path(module.__file__).parent)
    for root in sorted(roots):
        files = [*root.rglob("*.py"), *root.rglob("_native*.so"), *root.rglob("_native*.pyd")]
        for path in sorted(files):
            h.update(f"{path.relative_to(root.parent).as_posix()}\0".encode())
            h.update(path.read_bytes())
    return h.hexdigest()[:16]


def local_files() -> list[str]:
    """The user's own skill and check modules imported now (a scenario's `skills:`,
    `--skills`), by file."""
    return sorted(
        str(m.__file__)
        for name, m in list(sys.modules.items())
        if name.startswith(LOCAL_PREFIX) and getattr(m, "__file__", None)
    )


def local_code() -> str:
    """SHA-256 of the user's own skill and check modules imported now (a scenario's `skills:`,
    `--skills`), empty if none."""
    files = local_files()
    if not files:
        return ""
    h = hashlib.sha256()
    for file in files:
        h.update(f"{file}\0".encode())
        h.update(Path(file).read_bytes())
    return h.hexdigest()[:16]


def versions() -> dict[str, str]:
    """Everything a snapshot must be resumed with (compared as text)."""
    out = {"format": str(FORMAT), "code": _package_code(), "local_code": local_code()}
    out["python"] = platform.python_version()
    out["platform"] = f"{sys.platform}-{platform.machine()}"
    out["compiled"] = "yes" if native() is not None else "no"
    out.update({dist: _version(dist) for dist in _DISTRIBUTIONS})
    return out


_WHAT = {
    "code": "the framework's code",
    "local_code": "the scenario's own skill modules",
    "compiled": "the compiled per-step module in use (ORCHESTRATOR_PURE_PYTHON)",
}


def differences(recorded: dict[str, str], current: dict[str, str]) -> list[str]:
    """Each difference as 'what: snapshot X, here Y'."""
    out = []
    for name in sorted(set(recorded) | set(current)):
        a, b = recorded.get(name, "absent"), current.get(name, "absent")
        if a != b:
            out.append(f"{_WHAT.get(name, name)}: snapshot {a}, here {b}")
    return out
