"""The packed records of dynamics._numba.packing (a simulation's contact record is one): packing and the Python
views give back every array; compiled code's unpack reads the same numbers and writes through to the buffers;
unpackers give the named fields only; wrong records are refused; and the two store rules the contact code
relies on (a store through a record given to a kernel, a store at a constant index) hold in this numba."""

from typing import NamedTuple

import numpy as np
import pytest
from numba import njit

from dynamics._numba.packing import Packing, unpack


class Inner(NamedTuple):
    a: np.ndarray
    b: np.ndarray


class Record(NamedTuple):
    x: np.ndarray
    inner: Inner
    n: np.ndarray


class PackedRecord(NamedTuple):
    f: np.ndarray
    i: np.ndarray


LAYOUT = Packing(PackedRecord, Record(np.zeros(0), Inner(np.zeros((0, 3)), np.zeros((0, 2, 2), np.int64)),
                                      np.zeros(0, np.int64)))
_x_and_n = LAYOUT.unpacker("x", "n")


def _record(rng, k=4):
    return Record(rng.normal(size=k), Inner(rng.normal(size=(k + 1, 3)), rng.integers(-9, 9, (k, 2, 2))),
                  rng.integers(0, 100, k + 2))


@njit
def _read(pk):
    c = unpack(pk)
    return c.x.sum() + c.inner.a.sum() + c.inner.b.sum() + c.n.sum(), c.inner.a.shape[0], c.inner.b.shape[0]


@njit
def _into(c, k, value):
    c.inner.a[k, 2] = value  # (a variable index: the record is this kernel's argument)


@njit
def _write(pk, k, value):
    c = unpack(pk)
    c.x[0] = value  # a constant index through an unpacked record
    _into(c, k, value)


@njit
def _fields(pk):
    x, n = _x_and_n(pk)
    return x.sum() + n.sum()


def test_pack_and_views_give_back_every_array():
    rng = np.random.default_rng(0)
    r = _record(rng)
    pk = LAYOUT.pack(r)
    v = LAYOUT.views(pk)
    for a, b in zip((r.x, r.inner.a, r.inner.b, r.n), (v.x, v.inner.a, v.inner.b, v.n)):
        assert b.dtype == a.dtype and np.array_equal(a, b)
    assert pk.f.size == r.x.size + r.inner.a.size  # nothing but the arrays and the int header
    v.inner.a[1, 1] = 7.5  # the views are the buffers
    assert LAYOUT.views(pk).inner.a[1, 1] == 7.5


def test_compiled_unpack_reads_and_writes_the_buffers():
    rng = np.random.default_rng(1)
    for k in (1, 3, 6):
        r = _record(rng, k)
        pk = LAYOUT.pack(r)
        total, rows_a, rows_b = _read(pk)
        assert total == pytest.approx(r.x.sum() + r.inner.a.sum() + r.inner.b.sum() + r.n.sum(), rel=1e-14)
        assert (rows_a, rows_b) == (k + 1, k)
        _write(pk, k, 3.25)
        v = LAYOUT.views(pk)
        assert v.x[0] == 3.25 and v.inner.a[k, 2] == 3.25
        assert _fields(pk) == pytest.approx(v.x.sum() + v.n.sum(), rel=1e-14)


def test_wrong_records_are_refused():
    rng = np.random.default_rng(2)
    r = _record(rng)
    with pytest.raises(TypeError, match="leaf"):
        LAYOUT.pack(r._replace(n=r.n.astype(float)))
    with pytest.raises(TypeError, match="leaf"):
        LAYOUT.pack(r._replace(x=r.x.reshape(2, 2)))
    with pytest.raises(TypeError, match="arrays"):
        LAYOUT.pack(r._replace(inner=(r.inner.a,)))
    with pytest.raises(TypeError, match="float64 or int64"):
        Packing(PackedRecord, Record(np.zeros(0, np.float32), r.inner, r.n))
    with pytest.raises(TypeError, match="no field"):
        LAYOUT.unpacker("y")
