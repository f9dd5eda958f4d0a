"""Python-callable torques: a process-wide table of the callables of the running simulations, which the
compiled loop reaches through ``numba.objmode`` by slot number (one Python call per right-hand-side
evaluation).  A simulation registers its callable (:func:`register_callable`) and releases it when it ends."""

import threading

import numpy as np
from numba import objmode

from .._numba.boundary import python_kernel
from ..errors import InputError

_REGISTRY = {}
_NEXT_SLOT = [0]
_LOCK = threading.Lock()  # simulations on several threads register at once


def register_callable(fn, nv):
    """Store fn and return its slot; release it with :func:`release_callable`."""
    with _LOCK:
        slot = _NEXT_SLOT[0]
        _NEXT_SLOT[0] += 1
        _REGISTRY[slot] = (fn, nv)
    return slot


def release_callable(slot):
    _REGISTRY.pop(slot, None)


def _call_torque(slot, t, q, v, out):
    fn, nv = _REGISTRY[slot]
    tau = np.asarray(fn(float(t), q.copy(), v.copy()), dtype=np.float64)
    if tau.shape != (nv,):
        raise InputError(f"torque: the callable must return shape ({nv},), got {tau.shape}")
    out[:] = tau


@python_kernel  # holds the GIL: the objmode block needs it anyway (dynamics._numba.boundary)
def torque_callable(slot, t, q, v, tau):
    """tau = the registered callable of ``slot`` at (t, q, v), from compiled code."""
    with objmode():
        _call_torque(slot, t, q, v, tau)
