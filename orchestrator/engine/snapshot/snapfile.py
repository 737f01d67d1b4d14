"""The snapshot file: a header anyone may read, a signature, and the pickled world.

```
ORCHESTRATOR-SNAPSHOT 1\\n          magic and format
{"kind": "run", "scenario": ...}\\n  the header: one line of JSON (read without unpickling)
hmac-sha256 <64 hex digits>\\n      over the two lines above and the payload (signing.py)
<payload>                           zlib-compressed, engine/snapshot/pickler.py's bytes
```

Reading checks, in this order and before anything is unpickled: the magic, the format, the
header, the signature, then (the caller) the versions and the scenario. Each refusal says why.
"""

from __future__ import annotations

import json
import os
import tempfile
import zlib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from .pickler import SnapshotError
from .signing import KEY_ENV, NoKeyError, key_path, sign, verify
from .versions import FORMAT

__all__ = ["MAGIC", "SnapshotFile", "read_snapshot", "trust", "write_snapshot"]

MAGIC = b"ORCHESTRATOR-SNAPSHOT"
_LEVEL = 1
"""zlib level: 1 writes a 2.1 MB pickle as ~0.9 MB at a fraction of level 6's time
(BENCHMARKS.md, Snapshots)."""
_MAX_HEADER = 1 << 20


@dataclass(frozen=True)
class SnapshotFile:
    """A snapshot file read and verified (its payload not unpickled yet).

    Attributes:
        path: Where it was read from.
        header: Its header (kind, scenario, seed, time, state, break point, versions).
        payload: The pickled world (engine/snapshot/pickler.py), decompressed.
    """

    path: Path
    header: dict[str, Any]
    payload: bytes


def write_snapshot(path: Path, header: dict[str, Any], payload: bytes) -> int:
    """Write a signed snapshot to `path` (atomically: a crash leaves no half file).

    Returns:
        The file's size [bytes].

    Raises:
        SnapshotError: The file cannot be written (or the key cannot be made).
    """
    head = MAGIC + f" {FORMAT}\n".encode()
    line = json.dumps(header, sort_keys=True, allow_nan=False).encode() + b"\n"
    body = zlib.compress(payload, _LEVEL)
    signature = sign(head + line + body)
    data = head + line + f"hmac-sha256 {signature}\n".encode() + body
    path = Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent)
        with os.fdopen(fd, "wb") as f:
            f.write(data)
        os.replace(tmp, path)
    except OSError as exc:
        raise SnapshotError(f"cannot write the snapshot to {path}: {exc}") from None
    return len(data)


def read_snapshot(path: Path) -> SnapshotFile:
    """Read and verify a snapshot file; nothing in it is unpickled here.

    Raises:
        SnapshotError: Not a snapshot, another format, a broken header, or not signed with
            this user's key (the message says which, and what to do).
    """
    path = Path(path)
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise SnapshotError(f"{path}: cannot read the snapshot: {exc.strerror or exc}") from None
    head, _, rest = data.partition(b"\n")
    if not head.startswith(MAGIC + b" "):
        raise SnapshotError(f"{path}: not a snapshot file (it does not start with {MAGIC!r})")
    fmt = head[len(MAGIC) + 1 :].decode("ascii", "replace")
    if fmt != str(FORMAT):
        raise SnapshotError(
            f"{path}: snapshot format {fmt[:20]!r}, this version reads format {FORMAT} only"
        )
    line, _, rest = rest.partition(b"\n")
    sig_line, _, body = rest.partition(b"\n")
    try:
        if len(line) > _MAX_HEADER:
            raise ValueError("the header is too long")
        header = json.loads(line)
        if not isinstance(header, dict):
            raise ValueError("the header is not a JSON object")
    except (ValueError, UnicodeDecodeError) as exc:
        raise SnapshotError(f"{path}: broken snapshot header: {exc}") from None
    kind, _, signature = sig_line.decode("ascii", "replace").partition(" ")
    signed = head + b"\n" + line + b"\n" + body
    if kind != "hmac-sha256" or not _verified(signed, signature):
        where = f"${KEY_ENV}" if os.environ.get(KEY_ENV) else str(key_path())
        raise SnapshotError(
            f"{path}: not signed with this user's snapshot key ({where}): refused unread. A "
            "snapshot is a pickle, and loading a pickle runs the code it names: only "
            "snapshots written with your key are loaded. If you trust whoever wrote it, "
            f"`orchestrator snapshot trust {path}` signs it with yours"
        )
    try:
        payload = zlib.decompress(body)
    except zlib.error as exc:
        raise SnapshotError(f"{path}: broken snapshot payload: {exc}") from None
    return SnapshotFile(path, header, payload)


def _verified(signed: bytes, signature: str) -> bool:
    try:
        return verify(signed, signature)
    except NoKeyError:  # this user has written no snapshot: so not theirs
        return False


def trust(path: Path) -> None:
    """Sign the snapshot at `path` with this user's key (it keeps its header and payload):
    for a snapshot from someone the user trusts.

    Raises:
        SnapshotError: Not a snapshot file of this format.
    """
    path = Path(path)
    data = path.read_bytes()
    head, _, rest = data.partition(b"\n")
    if head != MAGIC + f" {FORMAT}".encode():
        raise SnapshotError(f"{path}: not a snapshot file of format {FORMAT}")
    line, _, rest = rest.partition(b"\n")
    _, _, body = rest.partition(b"\n")
    signature = sign(head + b"\n" + line + b"\n" + body)
    path.write_bytes(head + b"\n" + line + b"\n" + f"hmac-sha256 {signature}\n".encode() + body)
