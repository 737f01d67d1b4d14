"""One array of a snapshot's .npz payload, read without evaluating its header.

numpy reads the header of an .npy member (`{'descr': '<f8', 'fortran_order': False, 'shape':
(3,), }`) with `ast.literal_eval`: ~0.2 ms of Python's compiler per array, and a run snapshot
holds hundreds of small arrays (resuming one spent most of its unpacking there). The header
numpy writes for a plain numeric array is matched here exactly and the data read as its bytes;
anything else (another format version, a structured or object dtype, a header written by
another tool) goes to `np.lib.format.read_array` as before, with its own checks. The array is
the same either way, bit for bit, and writable.
"""

from __future__ import annotations

import re
from typing import IO

import numpy as np

__all__ = ["read_npy"]

_MAGIC = b"\x93NUMPY\x01\x00"
"""Format 1.0: what `np.savez` writes for headers under 64 KiB."""
_HEADER = re.compile(
    rb"\{'descr': '([<>|][biufc][1-9][0-9]?)', 'fortran_order': (True|False), "
    rb"'shape': \(((?:[0-9]{1,12}, )*[0-9]{0,12},?)\), \} *\n"
)
"""numpy's own rendering of a plain numeric array's header (`_write_array_header`)."""


def read_npy(f: IO[bytes], size: int, max_header: int) -> np.ndarray:
    """The array stored in `f`, an .npy member of `size` bytes (`max_header`: the longest
    header numpy may parse when it falls back to its own reader).

    Raises:
        ValueError: The member is not a valid .npy array (numpy's own messages when it falls
            back), or its data is shorter or longer than its header says.
    """
    head = f.read(10)
    m = None
    if head[:8] == _MAGIC and int.from_bytes(head[8:10], "little") <= _MAX_PLAIN_HEADER:
        head += f.read(int.from_bytes(head[8:10], "little"))
        m = _HEADER.fullmatch(head, 10)
    if m is None:
        return np.lib.format.read_array(
            _Prefixed(head, f), allow_pickle=False, max_header_size=max_header
        )
    descr, fortran, dims = m.groups()
    dtype = np.dtype(descr.decode())
    shape = tuple(int(d) for d in dims.split(b",") if d.strip())
    count = 1
    for n in shape:
        count *= n
    nbytes = count * dtype.itemsize
    if len(head) + nbytes != size:
        raise ValueError(f"the array's data is {size - len(head)} bytes, its header says {nbytes}")
    buf = bytearray(nbytes)
    if nbytes and f.readinto(buf) != nbytes:  # type: ignore[attr-defined]
        raise ValueError("the array's data ends early")
    flat = np.frombuffer(buf, dtype=dtype, count=count)
    return flat.reshape(shape[::-1]).transpose() if fortran == b"True" else flat.reshape(shape)


_MAX_PLAIN_HEADER = 4096
"""Longer headers are numpy's to read (a plain array's is under 128 bytes)."""


class _Prefixed:
    """`f` with `head` (already read from it) put back in front, for numpy's reader."""

    def __init__(self, head: bytes, f: IO[bytes]) -> None:
        self._head, self._f = head, f

    def read(self, n: int = -1) -> bytes:
        if n < 0:
            out, self._head = self._head + self._f.read(), b""
            return out
        out, self._head = self._head[:n], self._head[n:]
        return out + self._f.read(n - len(out)) if len(out) < n else out
