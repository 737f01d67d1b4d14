"""The snapshot file: a header anyone may read, a signature, and numeric arrays.

```
ORCHESTRATOR-SNAPSHOT 2\\n          magic and format
{"kind": "run", "scenario": ...}\\n  the header: one line of JSON
hmac-sha256 <64 hex digits>\\n      over the two lines above and the payload (signing.py)
<payload>                           an .npz archive of numeric arrays (numpy's own format)
```

Nothing in a snapshot is code, and reading one builds nothing but numbers, strings, lists,
dicts and numeric arrays (npy.py: numpy's plain header matched exactly, any other read by
`np.lib.format.read_array(..., allow_pickle=False)`): a snapshot
from anyone cannot run anything, with or without a key. The signature is for integrity (a
file changed or cut since it was written is refused) and provenance (this user wrote it).

Every read is bounded: the file at most `MAX_FILE_BYTES` (looked at before reading, and the
read itself stops there: /dev/zero, a pipe), the header line at most `MAX_HEADER_BYTES`, at
most `MAX_ARRAYS` arrays of at most `MAX_FILE_BYTES` in all as they unpack. Each refusal says
why; a crafted file is refused as fast as it is read (docs/time-travel.md, "Limits").
"""

from __future__ import annotations

import io
import json
import os
import stat
import tempfile
import zipfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .errors import SnapshotError
from .npy import read_npy
from .signing import KEY_ENV, NoKeyError, key_path, sign, verify
from .versions import FORMAT

__all__ = [
    "MAGIC",
    "MAX_FILE_BYTES",
    "SnapshotFile",
    "pack",
    "read_header",
    "read_snapshot",
    "trust",
    "write_snapshot",
]

MAGIC = b"ORCHESTRATOR-SNAPSHOT"
MAX_FILE_BYTES = 64 << 20
"""The largest snapshot file read, and the most its arrays may unpack to [bytes]."""
MAX_HEADER_BYTES = 1 << 20
MAX_ARRAYS = 10_000
_MAX_NPY_HEADER = 10_000


@dataclass(frozen=True)
class SnapshotFile:
    """A snapshot file read and verified (its arrays not unpacked yet: `arrays()`).

    Attributes:
        path: Where it was read from.
        header: Its header (kind, scenario, seed, time, state, break point, versions).
        payload: The .npz archive's bytes.
    """

    path: Path
    header: dict[str, Any]
    payload: bytes

    def arrays(self) -> dict[str, np.ndarray]:
        """The payload's arrays, by name (bounded: see the module docstring).

        Raises:
            SnapshotError: Not an .npz archive of numeric arrays within the limits.
        """
        return unpack(self.payload, self.path)


def pack(arrays: dict[str, np.ndarray]) -> bytes:
    """`arrays` as an .npz archive (compressed)."""
    buf = io.BytesIO()
    np.savez_compressed(buf, **arrays)  # type: ignore[arg-type]
    return buf.getvalue()


def unpack(payload: bytes, path: Path) -> dict[str, np.ndarray]:
    """The arrays of an .npz archive, never more than the limits, never an object array."""
    try:
        with zipfile.ZipFile(io.BytesIO(payload)) as zf:
            infos = zf.infolist()
            if len(infos) > MAX_ARRAYS:
                raise ValueError(f"{len(infos)} arrays, more than {MAX_ARRAYS}")
            total = sum(i.file_size for i in infos)
            if total > MAX_FILE_BYTES:
                raise ValueError(f"the arrays unpack to {total} bytes, over {MAX_FILE_BYTES}")
            out: dict[str, np.ndarray] = {}
            for info in infos:
                if not info.filename.endswith(".npy"):
                    raise ValueError(f"{info.filename[:60]!r} is not an array")
                with zf.open(info) as f:  # reads no more than the declared size
                    arr = read_npy(f, info.file_size, _MAX_NPY_HEADER)
                out[info.filename[:-4]] = arr
            return out
    except SnapshotError:
        raise
    except (ValueError, OSError, EOFError, zipfile.BadZipFile, RuntimeError, TypeError,
            OverflowError, MemoryError, KeyError, UnicodeDecodeError) as exc:  # fmt: skip
        raise SnapshotError(f"{path}: broken snapshot payload: {str(exc)[:200]}") from None


def write_snapshot(path: Path, header: dict[str, Any], payload: bytes) -> int:
    """Write a signed snapshot to `path` (atomically: a crash or a full disk leaves neither a
    half file nor a temporary one).

    Returns:
        The file's size [bytes].

    Raises:
        SnapshotError: The file cannot be written (a full disk, no permission: said as such),
            or the key cannot be made.
    """
    head = MAGIC + f" {FORMAT}\n".encode()
    line = json.dumps(header, sort_keys=True, allow_nan=False).encode() + b"\n"
    signature = sign(head + line + payload)
    data = head + line + f"hmac-sha256 {signature}\n".encode() + payload
    path = Path(path)
    tmp: str | None = None
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent)
        with os.fdopen(fd, "wb") as f:
            f.write(data)
        os.replace(tmp, path)
        tmp = None
    except OSError as exc:
        raise SnapshotError(
            f"cannot write the snapshot to {path}: {exc.strerror or exc} (nothing was written)"
        ) from None
    finally:
        if tmp is not None:
            try:
                os.unlink(tmp)
            except OSError:
                pass
    return len(data)


def _read_bounded(path: Path) -> bytes:
    """At most `MAX_FILE_BYTES` of `path`, refusing a larger file before reading it."""
    try:
        with open(path, "rb") as f:
            st = os.fstat(f.fileno())
            if st.st_size > MAX_FILE_BYTES:
                raise SnapshotError(
                    f"{path}: {st.st_size} bytes, more than a snapshot may be "
                    f"({MAX_FILE_BYTES >> 20} MiB): refused unread"
                )
            first = f.readline(len(MAGIC) + 8)
            if not first.startswith(MAGIC + b" "):
                raise SnapshotError(
                    f"{path}: not a snapshot file (it does not start with {MAGIC.decode()})"
                )
            left = MAX_FILE_BYTES + 1 - len(first)
            if stat.S_ISREG(st.st_mode):  # no buffer larger than the file: memory as its size
                left = min(left, max(st.st_size - len(first), 0) + 1)
            parts, size = [], 0
            while size < left:  # a pipe or a device: a chunk at a time, up to the limit
                chunk = f.read(min(left - size, 1 << 20))
                if not chunk:
                    break
                parts.append(chunk)
                size += len(chunk)
            rest = b"".join(parts)
    except IsADirectoryError:
        raise SnapshotError(f"{path}: a folder, not a snapshot file") from None
    except OSError as exc:
        raise SnapshotError(f"{path}: cannot read the snapshot: {exc.strerror or exc}") from None
    if len(first) + len(rest) > MAX_FILE_BYTES:
        raise SnapshotError(
            f"{path}: longer than a snapshot may be ({MAX_FILE_BYTES >> 20} MiB): refused"
        )
    return first + rest


def _split(path: Path, data: bytes) -> tuple[bytes, bytes, bytes, bytes]:
    """(magic line, header line, signature line, payload), each line without its newline."""
    head, _, rest = data.partition(b"\n")
    fmt = head[len(MAGIC) + 1 :].decode("ascii", "replace")
    if fmt != str(FORMAT):
        raise SnapshotError(
            f"{path}: snapshot format {fmt[:20]!r}, this version reads format {FORMAT} only "
            "(format 1 snapshots were pickles: take the snapshot again)"
        )
    end = rest.find(b"\n", 0, MAX_HEADER_BYTES + 1)
    if end < 0:
        raise SnapshotError(
            f"{path}: broken snapshot header: no end of line within {MAX_HEADER_BYTES} bytes"
        )
    line, rest = rest[:end], rest[end + 1 :]
    sig_line, _, body = rest.partition(b"\n")
    return head, line, sig_line[:200], body


def _header(path: Path, line: bytes) -> dict[str, Any]:
    try:
        header = json.loads(line)
    except (ValueError, UnicodeDecodeError, RecursionError) as exc:
        raise SnapshotError(f"{path}: broken snapshot header: {str(exc)[:200]}") from None
    if not isinstance(header, dict):
        raise SnapshotError(f"{path}: broken snapshot header: not a JSON object")
    return header


def read_header(path: Path) -> dict[str, Any]:
    """A snapshot file's header, signed or not (bounded like `read_snapshot`).

    Raises:
        SnapshotError: Not a snapshot, another format, too large, or a broken header.
    """
    path = Path(path)
    _, line, _, _ = _split(path, _read_bounded(path))
    return _header(path, line)


def read_snapshot(path: Path) -> SnapshotFile:
    """Read and verify a snapshot file (bounded: see the module docstring).

    Raises:
        SnapshotError: Not a snapshot, another format, too large, a broken header, or not
            signed with this user's key (the message says which, and what to do).
    """
    path = Path(path)
    data = _read_bounded(path)
    head, line, sig_line, body = _split(path, data)
    header = _header(path, line)
    kind, _, signature = sig_line.decode("ascii", "replace").partition(" ")
    if kind != "hmac-sha256" or not _verified(head + b"\n" + line + b"\n" + body, signature):
        where = f"${KEY_ENV}" if os.environ.get(KEY_ENV) else str(key_path())
        raise SnapshotError(
            f"{path}: not signed with this user's snapshot key ({where}): refused. The "
            "signature says the file is the one this user wrote, unchanged (a snapshot is data "
            "and cannot run code either way). If you trust whoever wrote it, "
            f"`orchestrator snapshot trust {path}` signs it with yours"
        )
    return SnapshotFile(path, header, body)


def _verified(signed: bytes, signature: str) -> bool:
    try:
        return verify(signed, signature)
    except NoKeyError:  # this user has written no snapshot: so not theirs
        return False


def trust(path: Path) -> None:
    """Sign the snapshot at `path` with this user's key (it keeps its header and payload):
    for a snapshot from someone the user trusts.

    Raises:
        SnapshotError: Not a snapshot file of this format, or it cannot be written.
    """
    path = Path(path)
    data = _read_bounded(path)
    head, line, _, body = _split(path, data)
    header = _header(path, line)
    unpack(body, path)  # a broken payload is refused now, not when it is resumed
    write_snapshot(path, header, body)
