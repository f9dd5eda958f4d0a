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

from .errors import InputError

#: below this many states a batch runs on the calling thread (thread hand-off costs ~20 us)
MIN_PARALLEL_BATCH = 64


def num_threads() -> int:
    env = os.environ.get("DYNAMICS_NUM_THREADS")
    if env:
        return max(1, int(env))
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not Linux
        return max(1, os.cpu_count() or 1)


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


def states(name, x, n, B=None):
    """Check one state (n,) or a batch (B, n); return (2-D float64 array, was_batched)."""
    try:
        arr = np.asarray(x, dtype=np.float64)
    except (TypeError, ValueError):
        raise InputError(f"{name}: expected an array of numbers of shape ({n},) or (B, {n})") from None
    if arr.ndim == 1 and arr.shape[0] == n:
        arr2 = arr[None, :]
        batched = False
    elif arr.ndim == 2 and arr.shape[1] == n and (B is None or arr.shape[0] == B):
        arr2 = arr
        batched = True
    else:
        bdesc = "B" if B is None else str(B)
        raise InputError(f"{name}: expected shape ({n},) or ({bdesc}, {n}), got {arr.shape}")
    if not np.all(np.isfinite(arr2)):
        raise InputError(f"{name}: contains non-finite values (nan or inf)")
    return np.ascontiguousarray(arr2), batched


def configurations(model, q):
    """Check q; a free joint's quaternion must be non-zero (it is normalised inside the kernels)."""
    Q, batched = states("q", q, model.nq)
    if model.floating_base:
        t = model.tree
        for code, k in zip(t.jtype, t.q_idx):
            if code == 2:
                norms = np.linalg.norm(Q[:, k + 3:k + 7], axis=1)
                if np.any(norms < 1e-8):
                    raise InputError(f"q: the quaternion q[{k + 3}:{k + 7}] of a floating joint is zero; "
                                     f"expected a unit quaternion (qx, qy, qz, qw)")
    return Q, batched


def gravity_vector(model, gravity):
    if gravity is None:
        return np.asarray(model.gravity, dtype=np.float64)
    g = np.asarray(gravity, dtype=np.float64)
    if g.shape != (3,):
        raise InputError(f"gravity: expected shape (3,), got {g.shape}")
    if not np.all(np.isfinite(g)):
        raise InputError("gravity: contains non-finite values (nan or inf)")
    return np.ascontiguousarray(g)


def external_forces(model, f_ext, B):
    """f_ext: None, (nbodies, 6) shared by every state, or (B, nbodies, 6).  Returns (1 or B, nb or 0, 6)."""
    nb = model.nbodies
    if f_ext is None:
        return np.zeros((1, 0, 6))
    F = np.asarray(f_ext, dtype=np.float64)
    if F.shape == (nb, 6):
        F = F[None]
    elif not (F.ndim == 3 and F.shape[1:] == (nb, 6) and F.shape[0] in (1, B)):
        raise InputError(f"f_ext: expected shape ({nb}, 6) or ({B}, {nb}, 6) (one [force, torque] per body "
                         f"in its body frame), got {F.shape}")
    if not np.all(np.isfinite(F)):
        raise InputError("f_ext: contains non-finite values (nan or inf)")
    return np.ascontiguousarray(F)


def check_model(model):
    from .model import Model

    if not isinstance(model, Model):
        raise InputError(f"model: expected a dynamics.Model (from load_urdf), got {type(model).__name__}")


def broadcast(named):
    """Give every (name, 2-D array) the common batch size; a single state is repeated, other sizes are an
    error naming the argument."""
    B = max(X.shape[0] for _, X in named)
    out = []
    for name, X in named:
        if X.shape[0] not in (1, B):
            raise InputError(f"{name}: expected a batch of {B} (or one state), got {X.shape[0]}")
        out.append(X if X.shape[0] == B else np.ascontiguousarray(np.broadcast_to(X, (B, X.shape[1]))))
    return out
