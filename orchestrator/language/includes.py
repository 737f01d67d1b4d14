"""Where a `machine:` reference may lead: inside the including file's directory tree, a
directory allowed with `--allow-path`, or a bundled machine — nowhere else.

A machine or scenario from someone else must not be able to read `/etc/shadow` or
`../../secrets.yaml` into an error message: a reference that leaves the allowed directories is
refused before the file is opened, and the refusal names the reference, never the file's text.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from .bundled import bundled_folder, bundled_names, bundled_path, is_file
from .diagnostics import clip
from .limits import InputLimits

__all__ = ["Resolved", "resolve_include"]


@dataclass(frozen=True)
class Resolved:
    """A reference resolved to a file (`path`), or refused (`error`, the reason)."""

    path: Path | None = None
    error: str | None = None
    valid: tuple[str, ...] = ()


def _inside(path: Path, root: Path) -> bool:
    return path == root or path.is_relative_to(root)


def resolve_include(
    ref: str,
    including: Path,
    allow: Sequence[Path],
    limits: InputLimits,
    what: str = "machine file",
) -> Resolved:
    """Resolve the `machine:` reference `ref` written in the file `including`.

    Args:
        ref: The reference as written: a path relative to the including file, or a bundled name.
        including: The file it is written in.
        allow: Further directories whose files may be included (`--allow-path`).
        limits: `max_ref_chars` bounds the reference's length.
        what: How messages call the reference.

    Returns:
        The file, or why the reference is refused.
    """
    if len(ref) > limits.max_ref_chars:
        return Resolved(
            error=f"the machine reference is {len(ref)} characters long, more than "
            f"{limits.max_ref_chars} (limit max_ref_chars)"
        )
    if "\x00" in ref or not ref.strip():
        return Resolved(error=f"{clip(ref)!r} is not a file name")
    base = including.parent
    candidate = base / ref
    if is_file(candidate):
        try:
            real = candidate.resolve()
        except (OSError, RuntimeError):  # a symlink loop
            return Resolved(error=f"cannot resolve {clip(ref)!r}")
        roots = [base.resolve(), bundled_folder("machines").resolve()]
        roots += [Path(a).resolve() for a in allow]
        if not any(_inside(real, root) for root in roots):
            return Resolved(
                error=f"machine file {clip(ref)!r} is outside {clip(str(base), 120)} (a machine "
                "may include files in its own directory tree or bundled machines; allow another "
                "directory with --allow-path DIR)"
            )
        return Resolved(path=candidate)
    bundled = bundled_path("machines", ref)
    if bundled is not None:
        return Resolved(path=bundled)
    return Resolved(
        error=f"{what} {clip(ref)!r} not found (relative to {clip(str(base), 120)}, nor a "
        "bundled machine)",
        valid=tuple(bundled_names("machines")),
    )
