"""Pickling a running episode whole: MuJoCo's structs once each, views into memory as views.

A run binds numpy *views* once — into MjData (`ctx`, the guards, `StepLoop`, the guard bank,
the encoders), into MjModel (the conveyor, the tissue probe), into arrays of its own (the
encoders' fault flags are a view of the context's). Plain `pickle` would copy each view into an
array of its own and the restored run would write to one and read another. `SnapshotPickler`
keeps the aliasing:

* an `MjModel` or `MjData` is written once, by MuJoCo's own pickling (the whole state of the
  struct: derived quantities, warm start, the arena in use), and every reference to it is a
  persistent id. MuJoCo 4.0's pickling of MjData loses a few fields (the sleeping counters
  `nbody_awake`, `ntree_awake`, `nv_awake`, `solver_niter`, `solver_nnz`, `flg_rnepost`: a
  restored world with sleeping bodies then stops with "mj_sleep: found sleeping tree"), so the
  struct is restored once when it is written and every field that came back different is
  written too (`_patches`);
* a view into a struct's memory is written as (struct, field path, byte offset, shape,
  strides) and made again on the restored struct (`warning.number`, `opt.gravity`: fields of
  its sub-structs too);
* a view of a numpy array is written as (that array, offset, shape, strides): the array is
  pickled once, the views made on it;
* the compiled readers of MjData (world/native.py `REDUCERS`) are rebuilt on the restored
  MjData.

Everything else pickles as Python pickles it: every attribute of every object, so a new
attribute travels without being listed anywhere (a new kind of object that cannot be pickled
makes the snapshot fail, naming where it is: `unpicklable_path`).
"""

from __future__ import annotations

import bisect
import io
import pickle
import types
from collections.abc import Iterable
from typing import Any

import mujoco
import numpy as np

from ...exceptions import OrchestratorError
from ...world.native import REDUCERS

__all__ = ["SnapshotError", "dumps", "loads", "unpicklable_path"]

_STRUCTS = (mujoco.MjModel, mujoco.MjData)
_PROTOCOL = 5


class SnapshotError(OrchestratorError):
    """A snapshot cannot be written or read (the message says what and where)."""


def _array_fields(obj: Any, prefix: str, depth: int) -> Iterable[tuple[str, np.ndarray]]:
    """Every array a MuJoCo struct exposes, with its attribute path (sub-structs included:
    `warning.number`, `opt.gravity`, `vis.headlight.ambient`)."""
    for name in dir(obj):
        if name.startswith("_") or name == "model":
            continue
        try:
            value = getattr(obj, name)
        except Exception:  # noqa: S112 (a property that does not apply to this struct)
            continue
        if isinstance(value, np.ndarray):
            if value.nbytes:
                yield prefix + name, value
        elif depth and type(value).__module__.startswith("mujoco") and not callable(value):
            if not isinstance(value, (bytes, str, int, float, _STRUCTS)):
                yield from _array_fields(value, f"{prefix}{name}.", depth - 1)


class _Memory:
    """Where the arrays of the structs seen so far lie in memory, to find a view's field."""

    def __init__(self) -> None:
        self.structs: list[Any] = []
        self._index: dict[int, int] = {}
        self._starts: list[int] = []
        self._spans: list[tuple[int, int, int, str]] = []  # (start, end, struct, field)

    def add(self, struct: Any) -> int:
        k = self._index.get(id(struct))
        if k is not None:
            return k
        k = len(self.structs)
        self.structs.append(struct)  # kept alive: its id stays its own while pickling
        self._index[id(struct)] = k
        for path, arr in _array_fields(struct, "", 3):
            start, end = _extent(arr)  # a field may be strided: `warning.number`
            span = (start, end, k, path)
            i = bisect.bisect(self._starts, start)
            self._starts.insert(i, start)
            self._spans.insert(i, span)
        return k

    def find(self, lo: int, hi: int) -> tuple[int, str, int] | None:
        """(struct index, field path, byte offset of `lo` in the field) of the field holding
        the bytes [lo, hi), or None."""
        i = bisect.bisect(self._starts, lo) - 1
        while i >= 0:
            start, end, k, path = self._spans[i]
            if start <= lo and hi <= end:
                return k, path, lo - start
            if end <= lo and start < lo - (1 << 30):
                break
            i -= 1
        return None


def _extent(view: np.ndarray) -> tuple[int, int]:
    """The byte range [lo, hi) a non-empty view reads."""
    lo = hi = int(view.__array_interface__["data"][0])
    for n, stride in zip(view.shape, view.strides, strict=True):
        if stride < 0:
            lo += (n - 1) * stride
        else:
            hi += (n - 1) * stride
    return lo, hi + view.itemsize


def _root(view: np.ndarray) -> np.ndarray:
    root = view
    while isinstance(root.base, np.ndarray):
        root = root.base
    return root


def _view_of(
    base: np.ndarray, offset: int, shape: tuple, strides: tuple, dtype: np.dtype, writeable: bool
) -> np.ndarray:
    """A view of `base`'s memory (restores a view of a numpy array or a MuJoCo field)."""
    out = np.ndarray(shape, dtype, buffer=base, offset=offset, strides=strides)
    if not writeable:
        out.flags.writeable = False
    return out


class _Held:
    """An array interface on a field's memory that keeps the field (and so the struct) alive:
    numpy makes the view from it (a strided field cannot export a buffer)."""

    def __init__(self, interface: dict[str, Any], base: np.ndarray) -> None:
        self.__array_interface__ = interface
        self.base = base


def _field_view(
    struct: Any,
    path: str,
    offset: int,
    shape: tuple,
    strides: tuple,
    dtype: np.dtype,
    writeable: bool,
) -> np.ndarray:
    """A view into the field `path` of a restored MjModel or MjData, `offset` bytes from the
    field's first element."""
    field: Any = struct
    for part in path.split("."):
        field = getattr(field, part)
    start = int(field.__array_interface__["data"][0])
    interface = {
        "data": (start + offset, not writeable),
        "shape": shape,
        "strides": strides,
        "typestr": dtype.str,
        "descr": dtype.descr,
        "version": 3,
    }
    view = np.asarray(_Held(interface, field))
    lo, hi = _extent(view)
    f_lo, f_hi = _extent(field)
    if not (f_lo <= lo and hi <= f_hi):  # a struct of another size: not this snapshot's
        raise SnapshotError(f"a view into {type(struct).__name__}.{path} falls outside it")
    return view


class _Pickler(pickle.Pickler):
    def __init__(self, file: io.BytesIO, memory: _Memory) -> None:
        super().__init__(file, protocol=_PROTOCOL)
        self.memory = memory
        self.unresolved = 0

    def persistent_id(self, obj: Any) -> Any:
        if isinstance(obj, _STRUCTS):
            return ("mj", self.memory.add(obj))
        return None

    def reducer_override(self, obj: Any) -> Any:
        if type(obj) is np.ndarray:
            return self._array(obj)
        reduce = REDUCERS.get(type(obj))
        if reduce is not None:
            return reduce(obj)
        return NotImplemented

    def _array(self, arr: np.ndarray) -> Any:
        if arr.base is None or arr.size == 0 or arr.dtype.hasobject:
            return NotImplemented
        args = (arr.shape, arr.strides, arr.dtype, bool(arr.flags.writeable))
        lo, hi = _extent(arr)
        found = self.memory.find(lo, hi)  # by address: whatever made the view
        if found is not None:
            k, path, offset = found
            start = int(arr.__array_interface__["data"][0])
            return (_field_view, (self.memory.structs[k], path, offset + start - lo, *args))
        root = _root(arr)
        if type(root.base).__name__ == "PyCapsule":  # MuJoCo's memory, its struct not seen yet
            self.unresolved += 1  # pickled again once every struct is known
            return NotImplemented
        if root is arr or not root.flags.c_contiguous:
            # `arr` holds the memory itself (numpy's own, or a buffer numpy wraps: a restored
            # array's bytearray), or its holder is not in C order: by value
            return NotImplemented
        start = int(arr.__array_interface__["data"][0])
        offset = start - int(root.__array_interface__["data"][0])
        return (_view_of, (root, offset, *args))


class _Unpickler(pickle.Unpickler):
    def __init__(self, file: io.BytesIO, structs: list[Any]) -> None:
        super().__init__(file)
        self.structs = structs

    def persistent_load(self, pid: Any) -> Any:
        kind, k = pid
        if kind != "mj" or not 0 <= k < len(self.structs):
            raise pickle.UnpicklingError(f"unknown persistent id {pid!r}")
        return self.structs[k]


def dumps(root: Any, structs: Iterable[Any] = ()) -> bytes:
    """Pickle `root` and everything it reaches (see the module docstring).

    Args:
        root: The object graph.
        structs: MuJoCo structs `root` reaches (a hint: views into a struct met before the
            struct itself need it known; any other is found in a second pass).

    Raises:
        SnapshotError: Something in the graph cannot be pickled (the message says where).
    """
    memory = _Memory()
    for struct in structs:
        memory.add(struct)
    for _ in range(2):
        buf = io.BytesIO()
        pickler = _Pickler(buf, memory)
        try:
            pickler.dump(root)
        except (pickle.PicklingError, TypeError, AttributeError) as exc:
            raise SnapshotError(_why(root, exc)) from None
        if not pickler.unresolved:
            break  # else: every struct is known now, and the views find them
    else:
        raise SnapshotError(
            "a view into MuJoCo memory that no MjModel or MjData of the snapshot holds "
            "(a view into an array MuJoCo reallocates, or of a struct outside the episode)"
        )
    return pickle.dumps((_blobs(memory.structs), buf.getvalue()), protocol=_PROTOCOL)


def _fields(struct: Any) -> dict[str, Any]:
    """Every array (as bytes) and number a MuJoCo struct exposes, by attribute path."""
    out: dict[str, Any] = {path: arr.tobytes() for path, arr in _array_fields(struct, "", 3)}
    for name in dir(struct):
        value = getattr(struct, name, None) if not name.startswith("_") else None
        if isinstance(value, (bool, int, float)):
            out[name] = value
    return out


_UNSETTABLE = ("signature",)
"""Fields the bindings do not let anyone set (a compilation checksum MuJoCo does not check on
a step)."""


class _Blob:
    """One MuJoCo struct as written: its pickled state, without the copy of its MjModel an
    MjData's state begins with when that model is in the snapshot too (`model`, its index),
    and the fields MuJoCo's pickling does not bring back (`patches`)."""

    def __init__(self, kind: str, state: bytes, model: int | None = None) -> None:
        self.kind, self.state, self.model = kind, state, model
        self.patches: dict[str, Any] = {}

    def restore(self, structs: dict[int, Any]) -> Any:
        state = self.state
        model = structs[self.model] if self.model is not None else None
        if model is not None:  # the MjData's state with its model's put back
            state = state[:1] + model.__getstate__() + state[1:]
        cls = mujoco.MjData if self.kind == "MjData" else mujoco.MjModel
        struct = cls.__new__(cls)
        struct.__setstate__(state)
        if model is not None:  # on the snapshot's own MjModel (`data.model is model`)
            on_model = mujoco.MjData(model)
            mujoco.mj_copyData(on_model, model, struct)
            struct = on_model
        for path, value in self.patches.items():
            if isinstance(value, np.ndarray):
                _field(struct, path)[...] = value
            else:
                parent, _, name = path.rpartition(".")
                setattr(_field(struct, parent) if parent else struct, name, value)
        return struct


def _blobs(structs: list[Any]) -> list[_Blob]:
    """Every struct as a `_Blob`, each restored once here and compared field by field with
    the original: what differs is written as a patch (MuJoCo 4.0's MjData pickling loses the
    sleeping counters)."""
    models = {id(s): k for k, s in enumerate(structs) if isinstance(s, mujoco.MjModel)}
    states = {k: s.__getstate__() for k, s in enumerate(structs)}
    blobs: list[_Blob] = []
    for k, struct in enumerate(structs):
        state = states[k]
        blob = _Blob(type(struct).__name__, state)
        if isinstance(struct, mujoco.MjData):
            m = models.get(id(struct.model))
            if m is not None and state[1 : 1 + len(states[m])] == states[m]:
                blob = _Blob("MjData", state[:1] + state[1 + len(states[m]) :], m)
        blobs.append(blob)
    restored: dict[int, Any] = {}
    for k in _order(blobs):
        blob, struct = blobs[k], structs[k]
        again = restored[k] = blob.restore(restored)
        if isinstance(struct, mujoco.MjData):
            before, after = _fields(struct), _fields(again)
            for path, value in before.items():
                if after.get(path) != value and path not in _UNSETTABLE:
                    blob.patches[path] = (
                        _field(struct, path).copy() if isinstance(value, bytes) else value
                    )
    return blobs


def _order(blobs: list[_Blob]) -> list[int]:
    """Models before the data made on them."""
    return sorted(range(len(blobs)), key=lambda k: blobs[k].kind != "MjModel")


def _field(struct: Any, path: str) -> Any:
    for part in path.split("."):
        struct = getattr(struct, part)
    return struct


def loads(payload: bytes) -> Any:
    """The object graph `dumps` wrote, on fresh MuJoCo structs. Only for trusted bytes: this
    is pickle (engine/snapshot/signing.py checks a file before it comes here)."""
    blobs, main = pickle.loads(payload)  # noqa: S301 (signed by this user: signing.py)
    restored: dict[int, Any] = {}
    for k in _order(blobs):
        restored[k] = blobs[k].restore(restored)
    return _Unpickler(io.BytesIO(main), [restored[k] for k in range(len(blobs))]).load()


def unpicklable_path(root: Any, limit: int = 200_000) -> str | None:
    """Where in `root`'s graph the first object pickle refuses lies (`episode.executor...`),
    for the message of a failed snapshot; None if none is found."""
    seen: set[int] = set()
    stack: list[tuple[str, Any]] = [("", root)]
    probe = _Pickler(io.BytesIO(), _Memory())
    while stack and len(seen) < limit:
        path, obj = stack.pop()
        if id(obj) in seen or obj is None or isinstance(obj, (str, bytes, int, float, bool)):
            continue
        seen.add(id(obj))
        if isinstance(obj, (*_STRUCTS, np.ndarray, type, types.ModuleType)):
            continue
        if isinstance(obj, types.FunctionType) and (
            obj.__name__ == "<lambda>" or "<locals>" in obj.__qualname__
        ):
            return f"{path or 'the root'} (a local function {obj.__qualname__})"
        if isinstance(obj, (types.MethodType, types.BuiltinMethodType)):
            stack.append((f"{path}.__self__", getattr(obj, "__self__", None)))
            continue
        override = probe.reducer_override(obj)
        try:
            rv = obj.__reduce_ex__(_PROTOCOL) if override is NotImplemented else override
        except Exception as exc:
            return f"{path or 'the root'} ({type(obj).__module__}.{type(obj).__qualname__}: {exc})"
        if isinstance(rv, str):
            continue
        stack.extend(reversed(list(_children(path, obj, rv))))
    return None


def _children(path: str, obj: Any, rv: tuple) -> Iterable[tuple[str, Any]]:
    if isinstance(obj, dict):
        yield from ((f"{path}[{k!r}]", v) for k, v in obj.items())
        return
    if isinstance(obj, (list, tuple, set, frozenset)):
        yield from ((f"{path}[{i}]", v) for i, v in enumerate(obj))
        return
    args = rv[1] if len(rv) > 1 and isinstance(rv[1], tuple) else ()
    yield from ((f"{path}<arg{i}>", a) for i, a in enumerate(args))
    state = rv[2] if len(rv) > 2 else None
    if (
        isinstance(state, tuple)
        and len(state) == 2
        and all(isinstance(s, (dict, type(None))) for s in state)
    ):
        state = {**(state[0] or {}), **(state[1] or {})}
    if isinstance(state, dict):
        yield from ((f"{path}.{k}", v) for k, v in state.items())
    elif state is not None:
        yield (f"{path}<state>", state)
    for i, item in enumerate(rv[3] if len(rv) > 3 and rv[3] is not None else ()):
        yield (f"{path}[{i}]", item)
    for k, v in rv[4] if len(rv) > 4 and rv[4] is not None else ():
        yield (f"{path}[{k!r}]", v)


def _why(root: Any, exc: Exception) -> str:
    where = unpicklable_path(root)
    return f"cannot snapshot the run: {exc}" + (f" at {where}" if where else "")
