"""Input checking at the public entry and batch dispatch over threads.

Every public function accepts one state (q of shape (nq,)) or a batch (B, nq).  Arguments are checked here
once (shape, dtype, finiteness) and turned into C-contiguous float64 2-D arrays; the compiled ``*_batch``
kernels then loop over states with one workspace per chunk.  A large batch is split into one chunk per core
and the chunks run on a shared thread pool: the kernels are ``nogil`` and keep no state between calls, so
concurrent calls from any number of threads are safe.
"""

import os
import threading
from concurrent.futures import ThreadPoolExecutor

import numpy as np
from .jit import kernel

from .errors import InputError
from .model import Model

#: below this many states a batch runs on the calling thread (thread hand-off costs ~20 us)
MIN_PARALLEL_BATCH = 64


class Kernel:
    """Call a numba kernel through its compiled entry point once it has been compiled.

    numba's dispatcher re-derives the types of every argument on each call (~4 us for the model's tuple of
    arrays); the public functions pass arguments whose types never vary (C-contiguous, writable float64
    states, the model's read-only arrays), so after the first call the single compiled overload is called
    directly.  If a second overload ever appears, calls go back through the dispatcher.
    """

    def __init__(self, dispatcher):
        self.dispatcher = dispatcher
        self.entry = None

    def __call__(self, *args):
        if self.entry is not None:
            return self.entry(*args)
        out = self.dispatcher(*args)
        overloads = list(self.dispatcher.overloads.values())
        if len(overloads) == 1:
            self.entry = overloads[0].entry_point
        return out


_threads = None


def num_threads() -> int:
    """Threads a batch is spread over: $DYNAMICS_NUM_THREADS, else the cores this process may use."""
    global _threads
    if _threads is None:
        env = os.environ.get("DYNAMICS_NUM_THREADS")
        if env:
            _threads = max(1, int(env))
        else:
            try:
                _threads = max(1, len(os.sched_getaffinity(0)))
            except AttributeError:  # pragma: no cover - not Linux
                _threads = max(1, os.cpu_count() or 1)
    return _threads


_pool = None
_pool_lock = threading.Lock()


def _executor():
    global _pool
    if _pool is None:
        with _pool_lock:
            if _pool is None:
                _pool = ThreadPoolExecutor(max_workers=num_threads(), thread_name_prefix="dynamics")
    return _pool


def run_chunks(kernel, tree, batched, shared, out):
    """Run ``kernel(tree, *batched_slices, *shared, out_slice)`` over chunks of the leading axis."""
    B = out.shape[0]
    nt = num_threads()
    if B < MIN_PARALLEL_BATCH or nt == 1:
        kernel(tree, *batched, *shared, out)
        return out
    bounds = np.linspace(0, B, nt + 1).astype(int)
    futures = []
    for lo, hi in zip(bounds[:-1], bounds[1:]):
        if hi > lo:
            args = [x[lo:hi] if x.shape[0] == B else x for x in batched]
            futures.append(_executor().submit(kernel, tree, *args, *shared, out[lo:hi]))
    for fut in futures:
        fut.result()
    return out


@kernel
def _first_nonfinite(X):
    """Index of the first row of X holding a nan or inf, or -1."""
    for b in range(X.shape[0]):
        for k in range(X.shape[1]):
            if not np.isfinite(X[b, k]):
                return b
    return -1


_first_nonfinite_k = Kernel(_first_nonfinite)


def states(name, x, n, B=None):
    """Check one state (n,) or a batch (B, n); return (C-contiguous writable 2-D float64 array, batched)."""
    if (type(x) is np.ndarray and x.dtype == np.float64 and x.ndim == 1 and x.shape[0] == n
            and x.flags.c_contiguous):
        arr2 = x.reshape(1, n)
        batched = False
    else:
        try:
            arr = np.asarray(x)
            if arr.dtype.kind not in "fiu":  # complex, bool, strings, objects: not joint coordinates
                raise TypeError
            arr = arr.astype(np.float64, copy=False)
        except (TypeError, ValueError):
            raise InputError(f"{name}: expected an array of real numbers of shape ({n},) or (B, {n})") from None
        if arr.ndim == 1 and arr.shape[0] == n:
            arr2 = arr[None, :]
            batched = False
        elif arr.ndim == 2 and arr.shape[1] == n and (B is None or arr.shape[0] == B):
            arr2 = arr
            batched = True
        else:
            bdesc = "B" if B is None else str(B)
            raise InputError(f"{name}: expected shape ({n},) or ({bdesc}, {n}), got {arr.shape}")
        arr2 = np.ascontiguousarray(arr2)
    if not arr2.flags.writeable:  # one compiled signature: writable arrays only
        arr2 = arr2.copy()
    bad = _first_nonfinite_k(arr2)
    if bad >= 0:
        where = f" (state {bad})" if batched else ""
        raise InputError(f"{name}: contains non-finite values (nan or inf){where}")
    return arr2, batched


@kernel
def _first_zero_quaternion(Q, starts):
    for b in range(Q.shape[0]):
        for k in starts:
            if Q[b, k] * Q[b, k] + Q[b, k + 1] * Q[b, k + 1] + Q[b, k + 2] * Q[b, k + 2] + Q[b, k + 3] * Q[b, k + 3] < 1e-16:
                return k
    return -1


_first_zero_quaternion_k = Kernel(_first_zero_quaternion)


def vector(name, x, n):
    """One real vector of length n, checked like every state: a fresh C-contiguous float64 array."""
    X, batched = states(name, x, n)
    if batched:
        raise InputError(f"{name}: expected shape ({n},), got {np.shape(x)}")
    return X[0].copy()


def is_state(x, n):
    """True for a C-contiguous writable float64 vector of length n: the fast single-state path."""
    return (type(x) is np.ndarray and x.dtype == np.float64 and x.shape == (n,) and x.flags.c_contiguous
            and x.flags.writeable)


@kernel
def inputs_ok(tree, q, vecs):
    """Whether q and every vector of ``vecs`` are finite and each free joint's quaternion is non-zero
    (the single-state kernels call this; on False the public function takes its general path, which
    says exactly what is wrong)."""
    for k in range(q.shape[0]):
        if not np.isfinite(q[k]):
            return False
    for x in vecs:
        for k in range(x.shape[0]):
            if not np.isfinite(x[k]):
                return False
    for i in range(tree.jtype.shape[0]):
        if tree.jtype[i] == 2:
            k = tree.q_idx[i] + 3
            if q[k] * q[k] + q[k + 1] * q[k + 1] + q[k + 2] * q[k + 2] + q[k + 3] * q[k + 3] < 1e-16:
                return False
    return True


def configurations(model, q):
    """Check q; a free joint's quaternion must be non-zero (it is normalised inside the kernels)."""
    Q, batched = states("q", q, model.nq)
    if model.floating_base:
        k = _first_zero_quaternion_k(Q, model.quaternion_starts)
        if k >= 0:
            raise InputError(f"q: the quaternion q[{k}:{k + 4}] of a floating joint is zero; "
                             f"expected a unit quaternion (qx, qy, qz, qw)")
    return Q, batched


def gravity_vector(model, gravity):
    if gravity is None:
        return np.array(model.gravity)  # a writable copy: one compiled signature
    g = np.asarray(gravity, dtype=np.float64)
    if g.shape != (3,):
        raise InputError(f"gravity: expected shape (3,), got {g.shape}")
    if not np.all(np.isfinite(g)):
        raise InputError("gravity: contains non-finite values (nan or inf)")
    return np.array(g)


_NO_FORCES = np.zeros((1, 0, 6))  # empty: the kernels never write it


def external_forces(model, f_ext, B):
    """f_ext: None, (nbodies, 6) shared by every state, or (B, nbodies, 6).  Returns (1 or B, nb or 0, 6)."""
    nb = model.nbodies
    if f_ext is None:
        return _NO_FORCES
    F = np.asarray(f_ext, dtype=np.float64)
    if F.shape == (nb, 6):
        F = F[None]
    elif not (F.ndim == 3 and F.shape[1:] == (nb, 6) and F.shape[0] in (1, B)):
        raise InputError(f"f_ext: expected shape ({nb}, 6) or ({B}, {nb}, 6) (one [force, torque] per body "
                         f"in its body frame), got {F.shape}")
    if not np.all(np.isfinite(F)):
        raise InputError("f_ext: contains non-finite values (nan or inf)")
    return np.array(F, order="C")


def check_model(model):
    if not isinstance(model, Model):
        raise InputError(f"model: expected a dynamics.Model (from load_urdf), got {type(model).__name__}")


def batch_of(Q, named):
    """The batch size B of q and the other (name, 2-D array) arguments, each of which has B rows or one;
    returns q repeated to B rows if it was a single state (the kernels read one-row arguments for every
    state)."""
    B = Q.shape[0]
    for _, X in named:
        if X.shape[0] != 1:
            if B != 1 and X.shape[0] != B:
                break
            B = X.shape[0]
    for name, X in (("q", Q),) + tuple(named):
        if X.shape[0] not in (1, B):
            raise InputError(f"{name}: expected a batch of {B} (or one state), got {X.shape[0]}")
    if Q.shape[0] != B:
        Q = np.ascontiguousarray(np.broadcast_to(Q, (B, Q.shape[1])))
    return Q, B


def configurations_and_velocities(model, q, v):
    """Check q and v together: (Q, V) with a common batch size, and whether the call was batched."""
    check_model(model)
    Q, bq = configurations(model, q)
    V, bv = states("v", v, model.nv)
    Q, V = broadcast((("q", Q), ("v", V)))
    return Q, V, bq or bv


def broadcast(named):
    """Give every (name, 2-D array) the common batch size; a single state is repeated, other sizes are an
    error naming the argument."""
    B = 1
    same = True
    for _, X in named:
        if X.shape[0] != B:
            same = B == 1 and X is named[0][1]
            B = max(B, X.shape[0])
    if same and all(X.shape[0] == B for _, X in named):
        return [X for _, X in named]
    out = []
    for name, X in named:
        if X.shape[0] not in (1, B):
            raise InputError(f"{name}: expected a batch of {B} (or one state), got {X.shape[0]}")
        out.append(X if X.shape[0] == B else np.ascontiguousarray(np.broadcast_to(X, (B, X.shape[1]))))
    return out
