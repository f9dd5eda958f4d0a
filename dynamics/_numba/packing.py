"""A record of many arrays packed into two buffers, so that compiled code passes two arrays, not dozens.

Why: numba passes a tuple to a compiled function as its flattened members, every array as its whole struct
(pointer, shape, strides, owner), and a simulation's right-hand side is a function the solver calls through
such a boundary thousands of times.  Measured on Go1's right-hand side (a problem without contact given extra
unused 3x3 arrays): +20 arrays 4.19 -> 4.29 us, +40 -> 4.73 us, +80 -> 4.98 us; a sample's emit 1.64 -> 2.47
us at +40.  The contact record alone held 37 arrays.

A :class:`Packing` is the layout of one kind of record: a NamedTuple (nested NamedTuples allowed) whose leaves
are C-contiguous float64 or int64 arrays of fixed ndims.  :meth:`Packing.pack` copies a record into a packed
NamedTuple ``(f, i)``: ``f`` every float array, ``i`` a header (each leaf's offset and shape) then every int
array.  Compiled code gets the record back with :func:`unpack`, a view of each leaf (``float_at`` / ``int_at``,
no reference counts), rebuilt where it is used: when the caller is inlined, only the fields it reads are
computed.  Python gets numpy views of the same memory with :meth:`Packing.views` (results read after a run).

The rule of :func:`dynamics._numba.float_at` holds: the packed buffers outlive every view.  And one rule of
numba's dead-code elimination: a store with a variable index into an array taken from a record that is not a
function's argument may be dropped (numba tracks aliases through an argument's attributes only), so code that
writes through an unpacked record either passes the record to a kernel (where it is an argument) or stores at
constant indices (numba never removes those).
"""

import numpy as np
from numba.extending import overload

from . import address, float_at, int_at

_F64, _I64 = np.dtype(np.float64), np.dtype(np.int64)
_LAYOUTS = {}  # packed NamedTuple class -> its Packing (found by unpack's overload at compile time)


def _leaves(x, path=()):
    """(path, array) for every leaf of the nested NamedTuple x, in field order."""
    if isinstance(x, tuple):
        for k, item in enumerate(x):
            yield from _leaves(item, path + (k,))
    else:
        yield path, x


class Packing:
    """The layout of the records shaped like ``example`` (module docstring), packed as ``cls`` (a NamedTuple
    class with the fields ``f`` and ``i``, named for the record so that numba types each kind apart)."""

    def __init__(self, cls, example):
        if cls._fields != ("f", "i"):
            raise TypeError(f"{cls.__name__}: a packed record has the fields (f, i)")
        self.cls = cls
        self.example = example
        self.kinds = []  # per leaf: (path, is_float, ndim, header position)
        pos = 0
        for path, a in _leaves(example):
            a = np.asarray(a)
            if a.dtype not in (np.float64, np.int64) or a.ndim == 0:
                raise TypeError(f"{cls.__name__}: leaf {path} is {a.dtype} {a.shape}, expected a float64 or "
                                "int64 array of one or more dimensions")
            self.kinds.append((path, a.dtype == np.float64, a.ndim, pos))
            pos += 1 + a.ndim
        self.header = pos
        _LAYOUTS[cls] = self

    def pack(self, record):
        """A new ``cls(f, i)`` holding a copy of every array of ``record`` (shaped like the example)."""
        leaves = [a for _, a in _leaves(record)]
        if len(leaves) != len(self.kinds):
            raise TypeError(f"{self.cls.__name__}: {len(leaves)} arrays, expected {len(self.kinds)}")
        header, floats, ints = [], [], []
        at = [0, self.header]  # next free item in f, in i
        for a, (path, is_float, ndim, pos) in zip(leaves, self.kinds):
            want = _F64 if is_float else _I64
            if not isinstance(a, np.ndarray) or a.ndim != ndim or (a.dtype is not want and a.dtype != want):
                raise TypeError(f"{self.cls.__name__}: leaf {path} is {np.asarray(a).dtype} {np.shape(a)}, "
                                "unlike the example")
            k = 0 if is_float else 1
            header.append(at[k])
            header.extend(a.shape)
            (floats if is_float else ints).append(a.ravel())
            at[k] += a.size
        f = np.concatenate(floats) if floats else np.zeros(0)
        i = np.concatenate([np.array(header, np.int64), *ints])
        return self.cls(f, i)

    def views(self, packed):
        """The record of ``packed`` as numpy views of its buffers (Python's side: read or write in place)."""
        f, i = packed
        items = []
        for path, is_float, ndim, pos in self.kinds:
            shape = tuple(int(s) for s in i[pos + 1:pos + 1 + ndim])
            start = int(i[pos])
            items.append((f if is_float else i)[start:start + int(np.prod(shape))].reshape(shape))
        return _rebuild(self.example, iter(items))

    def source(self, fields=None):
        """The body of a compiled unpack: the example's classes rebuilt from views (:func:`unpack`); with
        ``fields`` (top-level field names), a tuple of those fields only (:meth:`unpacker`)."""
        ns = {"float_at": float_at, "int_at": int_at, "address": address}
        leaf = iter(self.kinds)

        def build(x):
            if isinstance(x, tuple):
                name = f"C{len(ns)}"
                ns[name] = type(x)
                return f"{name}({', '.join(build(item) for item in x)})"
            _, is_float, ndim, pos = next(leaf)
            shape = "".join(f"h[{pos + 1 + d}], " for d in range(ndim))
            return f"{'float_at(fb' if is_float else 'int_at(ib'}, h[{pos}], ({shape}))"
        if fields is None:
            body = build(self.example)
        else:
            items = {name: build(x) for name, x in zip(self.example._fields, self.example)}
            body = "(" + "".join(f"{items[name]}, " for name in fields) + ")"
        src = f"def impl(packed):\n    h = packed.i\n    fb, ib = address(packed.f), address(h)\n    return {body}"
        return src, ns

    def unpacker(self, *fields):
        """A function ``f(packed)`` that gives, in compiled code, the tuple of the record's top-level ``fields``
        only (views, as :func:`unpack`): the checks that run on every call read what they need, whatever the
        optimiser makes of a whole record that only a rarer branch passes on."""
        unknown = [f for f in fields if f not in self.example._fields]
        if unknown:
            raise TypeError(f"{self.cls.__name__}: no field {unknown}; fields: {self.example._fields}")

        def stub(packed):
            raise NotImplementedError("compiled code only")

        def typer(packed):
            return self.compiled(fields) if getattr(packed, "instance_class", None) is self.cls else None
        overload(stub, inline="always")(typer)
        return stub

    def compiled(self, fields=None):
        """The implementation of :func:`unpack` (``fields`` None) or of an :meth:`unpacker` for numba."""
        src, ns = self.source(fields)
        exec(src, ns)
        return ns["impl"]


def _rebuild(example, items):
    if isinstance(example, tuple):
        return type(example)(*(_rebuild(x, items) for x in example))
    return next(items)


def unpack(packed):
    """The record of ``packed`` (a Packing's ``cls``) as views of its buffers, in compiled code."""
    raise NotImplementedError("unpack: compiled code only (Packing.views in Python)")


@overload(unpack, inline="always")
def _ov_unpack(packed):
    layout = _LAYOUTS.get(getattr(packed, "instance_class", None))
    return None if layout is None else layout.compiled()
