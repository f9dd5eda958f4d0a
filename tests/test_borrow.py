"""dynamics._numba.borrow: owner-less views of a nested value, in compiled code.

The simulation's entry points borrow the whole problem (NamedTuples of arrays, nested) once per run; the views
must read and write the caller's memory, leave every array's reference count as it was (a view has no owner;
anything passed through unchanged keeps a reference of its own).
"""

import sys
from typing import NamedTuple

import numpy as np
from numba import njit

from dynamics._numba import borrow


class Inner(NamedTuple):
    x: np.ndarray  # float64 (3,)
    m: np.ndarray  # float64 (2, 2)
    flags: np.ndarray  # bool (2,)


class Outer(NamedTuple):
    inner: Inner
    idx: np.ndarray  # int64 (4,)
    rec: np.ndarray  # a record array: passed through as it is (not viewable)
    strided: np.ndarray  # not C-contiguous: passed through
    k: float
    pair: tuple  # a plain tuple of two arrays


@njit
def _touch(o, n):
    """Borrow ``o`` n times; through the views, add 1 to every float and int item and flip the flags."""
    for _ in range(n):
        b = borrow(o)
        b.inner.x[0] += 1.0
        b.inner.m[1, 0] += 1.0
        b.inner.flags[0] = not b.inner.flags[0]
        b.idx[3] += 1
        b.pair[0][0] += 1.0
        b.pair[1][1] += 1
        b.rec[0]["a"] += 1.0
        b.strided[1] += 1.0
    b = borrow(o)
    return b.k + b.inner.x.shape[0] + b.inner.m.shape[1] + b.pair[1].shape[0]


def _outer():
    rec = np.zeros(2, dtype=[("a", np.float64), ("b", np.int64)])
    return Outer(Inner(np.zeros(3), np.zeros((2, 2)), np.zeros(2, bool)), np.arange(4), rec,
                 np.zeros(6)[::2], 2.5, (np.zeros(2), np.zeros(3, np.int64)))


def _arrays(o):
    i = o.inner
    return [i.x, i.m, i.flags, o.idx, o.rec, o.strided, o.pair[0], o.pair[1]]


def test_views_write_through_to_the_callers_memory():
    o = _outer()
    assert _touch(o, 5) == 2.5 + 3 + 2 + 3
    assert o.inner.x.tolist() == [5.0, 0.0, 0.0]
    assert o.inner.m.tolist() == [[0.0, 0.0], [5.0, 0.0]]
    assert o.inner.flags.tolist() == [True, False]  # flipped five times
    assert o.idx.tolist() == [0, 1, 2, 8]
    assert o.pair[0].tolist() == [5.0, 0.0] and o.pair[1].tolist() == [0, 5, 0]
    assert o.rec["a"].tolist() == [5.0, 0.0]
    assert o.strided.tolist() == [0.0, 5.0, 0.0]


def test_reference_counts_are_left_as_they_were():
    o = _outer()
    _touch(o, 1)  # compiled
    before = [sys.getrefcount(a) for a in _arrays(o)]
    _touch(o, 10_000)
    assert [sys.getrefcount(a) for a in _arrays(o)] == before
