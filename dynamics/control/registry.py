"""Python-callable torques: a process-wide table of the callables of the running simulations, by slot number
(the core's source calls its callable back with the GIL taken, once per right-hand-side evaluation:
:func:`dynamics.simulation.native.core_source`).  A simulation registers its callable (:func:`register_callable`)
and releases it when it ends."""

import threading


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

