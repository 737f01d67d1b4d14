"""A snapshot's arrays read without numpy's header evaluation are numpy's arrays, bit for bit."""

from __future__ import annotations

import io
import zipfile
from pathlib import Path

import numpy as np
import pytest

from orchestrator.engine.snapshot.errors import SnapshotError
from orchestrator.engine.snapshot.snapfile import pack, unpack

ARRAYS = {
    "f8": np.array([0.1, -2.5e-300, np.inf, np.nan]),
    "f4_2d": np.arange(6, dtype=np.float32).reshape(2, 3),
    "scalar": np.array(7, dtype=np.int64),
    "fortran": np.asfortranarray(np.arange(12.0).reshape(3, 4)),
    "bool": np.array([True, False, True]),
    "empty": np.zeros((0, 7)),
    "big_endian": np.arange(5, dtype=">i4"),
    "complex": np.array([1 + 2j, -3j]),
    "text": np.array(["pick", "place"]),  # not a plain numeric header: numpy reads it
    "record": np.zeros(2, dtype=[("a", "<f8"), ("b", "<i4")]),  # nor this one
}


def _numpy(payload: bytes) -> dict[str, np.ndarray]:
    with zipfile.ZipFile(io.BytesIO(payload)) as zf:
        return {
            n[:-4]: np.lib.format.read_array(zf.open(n), allow_pickle=False) for n in zf.namelist()
        }


def test_every_array_is_numpys_own_reading_bit_for_bit_and_writable():
    payload = pack(ARRAYS)
    ours, theirs = unpack(payload, Path("x.snap")), _numpy(payload)
    assert ours.keys() == theirs.keys() == ARRAYS.keys()
    for name, arr in ours.items():
        ref = theirs[name]
        assert arr.dtype == ref.dtype and arr.shape == ref.shape, name
        assert arr.tobytes() == ref.tobytes(), name
        assert arr.flags.f_contiguous == ref.flags.f_contiguous, name
        assert arr.flags.writeable, name


def _member(header: bytes, data: bytes) -> bytes:
    """An .npz with one member `a.npy`: numpy's magic, `header` padded as numpy pads it."""
    header += b" " * (-(10 + len(header) + 1) % 64) + b"\n"
    npy = b"\x93NUMPY\x01\x00" + len(header).to_bytes(2, "little") + header + data
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w") as zf:
        zf.writestr("a.npy", npy)
    return buf.getvalue()


@pytest.mark.parametrize(
    ("header", "data"),
    [
        (b"{'descr': '<f8', 'fortran_order': False, 'shape': (4,), }", b"\0" * 16),
        (b"{'descr': '<f8', 'fortran_order': False, 'shape': (2,), }", b"\0" * 24),
        (b"{'descr': '<f8', 'fortran_order': False, 'shape': (99999999999,), }", b"\0" * 8),
        (b"{'descr': '|O', 'fortran_order': False, 'shape': (1,), }", b"\0" * 8),
        (b"{'descr': '<f8', 'fortran_order': False, 'shape': (1,), 'x': __import__('os')}", b""),
    ],
    ids=["short", "long", "huge", "object", "code"],
)
def test_a_member_that_lies_about_its_data_or_holds_objects_is_refused(header, data):
    with pytest.raises(SnapshotError, match="broken snapshot payload"):
        unpack(_member(header, data), Path("x.snap"))
