"""Every input check of the public entry points, in one place.

Public functions accept one state (q of shape (nq,)) or a batch (B, nq).  Arguments are checked here once
(type, shape, finiteness, a quaternion or a planar joint's (cos, sin)) and turned into C-contiguous float64 2-D
arrays, which the core's batches take; the core's kernels never check.  Every error is an :class:`InputError`
whose message starts with the argument's name and says what was expected.

The single-state fast paths (``_core.rnea`` and the like) check their inputs in the bindings: exactly a float64
array of the right length, unit stride, finite, non-zero quaternions (``bindings/numpy.cpp``).  Anything else
returns None and the public function takes the general path here, which raises the same error as always, so every
message has one source.
"""

import math

import numpy as np

from . import _core
from .errors import InputError
from .joints import JOINT_FREE, KINDS
from .model import Model



# the first row of a checked 2-D float64 array holding a nan or inf (-1: none), and the first zero unit block
# (a quaternion, a planar joint's (cos, sin)) of model.unit_blocks in any row of Q: the core's loops, no copy
_first_nonfinite_k = _core.first_nonfinite
_first_zero_unit_k = _core.first_zero_unit


#: float64, the dtype the general path's fast checks compare with; NOT_ARRAYS: what a non-array raises there
F64 = np.dtype(np.float64)
NOT_ARRAYS = (AttributeError, TypeError)
#: what a single call into the core raises for a ``model`` that is not a Model (the general path then says so)
NOT_A_MODEL = (AttributeError, TypeError)


def check_model(model):
    if not isinstance(model, Model):
        raise InputError(f"model: expected a dynamics.Model (from load_urdf), got {type(model).__name__}")


def is_state(x, n):
    """True for a C-contiguous writable float64 vector of length n (the constrained single-state path)."""
    return (type(x) is np.ndarray and x.dtype == np.float64 and x.shape == (n,) and x.flags.c_contiguous
            and x.flags.writeable)


_KIND_NAMES = {"U": "strings", "S": "bytes", "c": "complex numbers", "b": "booleans", "O": "Python objects",
               "M": "dates", "m": "time spans", "V": "records"}


def _real_array(name, x, expected):
    try:
        arr = np.asarray(x)
    except (TypeError, ValueError):  # ragged nested lists
        raise InputError(f"{name}: expected an array of real numbers of shape {expected}, got a ragged "
                         f"or mixed sequence") from None
    if arr.dtype.kind not in "fiu":  # complex, bool, strings, objects: not joint coordinates
        got = _KIND_NAMES.get(arr.dtype.kind, str(arr.dtype))
        raise InputError(f"{name}: expected an array of real numbers of shape {expected}, got {got}")
    return arr.astype(np.float64, copy=False)


def _length_hint(model, name, length, kind):
    """Why a vector of this length may have been passed: the usual mistakes, in words."""
    if model is None:
        return ""
    n = model.nq if kind == "q" else model.nv
    free = KINDS[JOINT_FREE].nq if kind == "q" else KINDS[JOINT_FREE].nv
    if not model.floating_base and length == n + free:
        return f"; did you mean load_urdf(..., floating_base=True)? ({length} = {n} + {free} free-flyer coordinates)"
    locked = model.info.get("locked_joints") or {}
    if locked:
        n_locked = sum(np.size(value) for value in locked.values())
        nv_of_nq = {k.nq: k.nv for k in KINDS.values()}  # one kind per nq (1, 4 or 7 numbers)
        if length == n + (n_locked if kind == "q" else sum(nv_of_nq.get(np.size(x), 0) for x in locked.values())):
            return (f"; this model has the joints {sorted(locked)[:8]} locked (dynamics.lock_joints): pass only "
                    f"the {n} coordinates of the others, in model.joint_names order")
    return ""


def states(name, x, n, model=None, kind="v"):
    """Check one state (n,) or a batch (B, n); return (C-contiguous writable 2-D float64 array, batched).
    With ``model``, a wrong length gets a hint at the likely mistake (``kind``: "q" or "v")."""
    if type(x) is np.ndarray and x.dtype is F64 and x.shape == (n,) and x.flags.c_contiguous and x.flags.writeable:
        arr2, batched = x.reshape(1, n), False
    else:
        arr = _real_array(name, x, f"({n},) or (B, {n})")
        if arr.ndim == 1 and arr.shape[0] == n:
            arr2, batched = arr[None, :], False
        elif arr.ndim == 2 and arr.shape[1] == n:
            arr2, batched = arr, True
        else:
            raise InputError(f"{name}: expected shape ({n},) or (B, {n}), got {arr.shape}"
                             + _length_hint(model, name, arr.shape[-1] if arr.ndim else 0, kind))
        arr2 = np.ascontiguousarray(arr2)
        if not arr2.flags.writeable:  # (the batches' outputs and inputs: writable, owned arrays)
            arr2 = arr2.copy()
    bad = _first_nonfinite_k(arr2)
    if bad >= 0:
        where = f" (state {bad})" if batched else ""
        raise InputError(f"{name}: contains non-finite values (nan or inf){where}")
    return arr2, batched


def vector(name, x, n):
    """One real vector of length n, checked like every state: a fresh C-contiguous float64 array."""
    if type(x) is np.ndarray and x.dtype is F64 and x.shape == (n,) and x.flags.c_contiguous:
        # the usual argument (simulate's q0, v0, a model's gravity): a copy, checked by the core's loop
        if _first_nonfinite_k(x.reshape(1, n)) >= 0:
            raise InputError(f"{name}: contains non-finite values (nan or inf)")
        return x.copy()
    X, batched = states(name, x, n)
    if batched:
        raise InputError(f"{name}: expected shape ({n},), got {np.shape(x)}")
    return X[0].copy()


def configurations(model, q, name="q"):
    """Check q; a free or spherical joint's quaternion, a planar joint's (cos, sin), must be non-zero (they are
    normalised inside the kernels)."""
    Q, batched = states(name, q, model.nq, model, "q")
    if model.unit_blocks.shape[0]:
        r = _first_zero_unit_k(Q, model.unit_blocks)
        if r >= 0:
            raise InputError(zero_unit_message(model, name, r))
    return Q, batched


def zero_unit_message(model, name, r):
    """What is wrong with row r of ``model.unit_blocks`` being zero in the configuration ``name``."""
    k, n = (int(x) for x in model.unit_blocks[r])
    i = int(np.searchsorted(model.tree.q_idx, k, side="right")) - 1
    jtype = model.joint_types[i]
    if n == 2:
        return (f"{name}: (cos theta, sin theta) {name}[{k}:{k + 2}] of the planar joint {model.joint_names[i]!r} "
                f"is zero; expected a unit vector: theta = 0 is [1, 0]")
    return (f"{name}: the quaternion {name}[{k}:{k + 4}] of a {jtype} joint is zero; expected a unit quaternion "
            f"in the order (x, y, z, w), scalar last: the identity is [0, 0, 0, 1]")


def broadcast(named):
    """Give every (name, 2-D array) the common batch size B: a one-row array is repeated, any other size is an
    error naming the argument.  Returns (arrays, B)."""
    B = next((X.shape[0] for _, X in named if X.shape[0] != 1), 1)  # the first batched argument sets B
    out = []
    for name, X in named:
        if X.shape[0] == B:
            out.append(X)
        elif X.shape[0] == 1:
            out.append(np.ascontiguousarray(np.broadcast_to(X, (B, X.shape[1]))))
        else:
            raise InputError(f"{name}: expected a batch of {B} (or one state), got {X.shape[0]}")
    return out, B


def state_batch(model, q, named):
    """q and the (name, value, size) vectors of one call, checked and broadcast to a common batch.

    Returns (Q, [X, ...], B, batched) where batched says whether any argument was a batch.
    """
    check_model(model)
    Q, batched = configurations(model, q)
    arrays = [("q", Q)]
    for name, x, n in named:
        X, b = states(name, x, n, model)
        arrays.append((name, X))
        batched = batched or b
    out, B = broadcast(arrays)
    return out[0], out[1:], B, batched


def gravity_vector(model, gravity):
    """The gravity of a call: model.gravity by default, else a finite (3,) vector (a fresh writable copy)."""
    if gravity is None:
        return np.array(model.gravity)
    return vector("gravity", gravity, 3)


_NO_FORCES = np.zeros((1, 0, 6))  # empty: the kernels never write it


def external_forces(model, f_ext, B):
    """f_ext: None, (nbodies, 6) shared by every state, or (B, nbodies, 6).  Returns (1 or B, nb or 0, 6)."""
    nb = model.nbodies
    if f_ext is None:
        return _NO_FORCES
    F = _real_array("f_ext", f_ext, f"({nb}, 6) or ({B}, {nb}, 6)")
    if F.shape == (nb, 6):
        F = F[None]
    elif not (F.ndim == 3 and F.shape[1:] == (nb, 6) and F.shape[0] in (1, B)):
        raise InputError(f"f_ext: expected shape ({nb}, 6) or ({B}, {nb}, 6) (one [force, torque] per body "
                         f"in its body frame), got {F.shape}")
    if not np.all(np.isfinite(F)):
        raise InputError("f_ext: contains non-finite values (nan or inf)")
    return np.array(F, order="C")


def real_number(name, x, *, lo=None, lo_open=False, hi=None, allow_none=False):
    """A finite float within [lo, hi) (or (lo, hi) with lo_open); None passes when allow_none."""
    if x is None and allow_none:
        return None
    if type(x) is float and math.isfinite(x) and (lo is None or x > lo or (x == lo and not lo_open)) and \
            (hi is None or x < hi):
        return x  # the usual argument, within bounds: what the checks below return for it
    if isinstance(x, (bool, np.bool_)) or isinstance(x, (str, bytes)):
        raise InputError(f"{name}: expected a finite real number, got {x!r}")
    try:
        x = float(x)
    except (TypeError, ValueError, OverflowError):
        raise InputError(f"{name}: expected a finite real number, got {x!r}") from None
    if not math.isfinite(x):
        raise InputError(f"{name}: expected a finite real number, got {x!r}")
    if lo is not None and (x < lo or (lo_open and x == lo)):
        raise InputError(f"{name}: expected a value {'>' if lo_open else '>='} {lo:g}, got {x!r}")
    if hi is not None and x >= hi:
        raise InputError(f"{name}: expected a value < {hi:g}, got {x!r}")
    return x


def array(name, x, shape, *, nonneg=False):
    """A finite float64 array of exactly ``shape`` (a fresh C-contiguous copy)."""
    a = _real_array(name, x, shape)
    if a.shape != tuple(shape):
        raise InputError(f"{name}: expected shape {tuple(shape)}, got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise InputError(f"{name}: contains non-finite values (nan or inf)")
    if nonneg and np.any(a < 0):
        raise InputError(f"{name}: expected values >= 0")
    return np.array(a, order="C")


# -- frames and task-space arguments ----------------------------------------------------------------------

#: the ``reference`` argument's values and their kernel codes (Pinocchio's WORLD, LOCAL, LOCAL_WORLD_ALIGNED)
REFERENCES = {"world": 0, "local": 1, "local_world_aligned": 2}


def frame(model, f):
    """A frame given by name (``model.frame_names``) or index: its index (unknown names list the closest)."""
    if isinstance(f, (int, np.integer)) and not isinstance(f, (bool, np.bool_)):
        if not 0 <= f < len(model.frames):
            raise InputError(f"frame: index {f} out of range [0, {len(model.frames)})")
        return int(f)
    if not isinstance(f, str):
        raise InputError(f"frame: expected a frame name (str) or index (int), got {type(f).__name__}")
    return model.frame_index(f)


def reference(ref):
    """The kernel code of a ``reference`` name."""
    code = REFERENCES.get(ref) if isinstance(ref, str) else None
    if code is None:
        raise InputError(f"reference: expected one of {list(REFERENCES)}, got {ref!r}")
    return code


def rows(r):
    """Rows of a 6-row [linear; angular] quantity: None (all), a slice, or distinct indices in [0, 6)."""
    if r is None:
        return np.arange(6)
    if isinstance(r, slice):
        out = np.arange(6)[r]
    else:
        try:
            out = np.asarray(r)
        except Exception:
            out = np.zeros(0, object)
        if out.ndim != 1 or out.dtype.kind not in "iu":
            raise InputError(f"rows: expected None, a slice or a list of indices in [0, 6), got {r!r}")
    if out.size == 0 or out.min() < 0 or out.max() > 5 or np.unique(out).size != out.size:
        raise InputError(f"rows: expected distinct indices in [0, 6) (0-2 linear, 3-5 angular), got {r!r}")
    return np.ascontiguousarray(out, dtype=np.int64)


def poses(name, x, position_only=False):
    """Homogeneous poses: (4, 4) or (B, 4, 4) with a rotation part; with position_only also positions (3,) or
    (B, 3) (made poses with the identity rotation).  Returns ((n, 4, 4) array, batched)."""
    want = "(4, 4) or (B, 4, 4)" + (", or a position (3,) or (B, 3)" if position_only else "")
    T = _real_array(name, x, want)
    if not np.all(np.isfinite(T)):
        raise InputError(f"{name}: contains non-finite values (nan or inf)")
    if position_only and T.ndim in (1, 2) and T.shape[-1] == 3:
        P = T.reshape(-1, 3)
        out = np.zeros((P.shape[0], 4, 4))
        out[:, :3, :3] = np.eye(3)
        out[:, :3, 3] = P
        out[:, 3, 3] = 1.0
        return out, T.ndim == 2
    if T.ndim not in (2, 3) or T.shape[-2:] != (4, 4):
        raise InputError(f"{name}: expected shape {want}, got {T.shape}")
    batched = T.ndim == 3
    T = np.array(T.reshape(-1, 4, 4), order="C")
    if not position_only:
        R = T[:, :3, :3]
        dev = np.abs(R @ R.transpose(0, 2, 1) - np.eye(3)).max(axis=(1, 2))
        bad = np.flatnonzero((dev > 1e-6) | (np.linalg.det(R) < 0))
        if bad.size:
            where = f" (pose {bad[0]})" if batched else ""
            raise InputError(f"{name}: the rotation part{where} is not a rotation matrix (R R^T != 1 or det R < 0)")
    bottom = np.flatnonzero(np.abs(T[:, 3] - (0.0, 0.0, 0.0, 1.0)).max(axis=1) > 1e-9)
    if bottom.size:  # only the top three rows are read: a wrong bottom row would silently become [0, 0, 0, 1]
        row = ", ".join(f"{x:g}" for x in T[bottom[0], 3])
        where = f" (pose {bottom[0]})" if batched else ""
        raise InputError(f"{name}: the bottom row{where} is [{row}]; expected [0, 0, 0, 1] (a homogeneous "
                         f"transform)")
    return T, batched


# -- a singular mass matrix: one rule (ABA's pivot), one message ------------------------------------------------

def singular_joint_error(model, body, what):
    """The InputError for a mass matrix found singular at ``body``'s joint, saying what that joint really moves:
    nothing (no mass or inertia below it), or mass that gives it no inertia along its motion (a point mass on
    its axis, or inertias too far apart in scale for float64)."""
    below = np.zeros(model.nbodies, bool)
    below[body] = True
    for i in range(body + 1, model.nbodies):  # parents[i] < i: one forward pass marks the subtree
        below[i] = model.tree.parents[i] >= 0 and below[model.tree.parents[i]]
    mass = float(np.sum(model.tree.mass[below]))
    name = model.joint_names[body]
    if mass == 0.0 and not np.any(model.tree.Io[below]):
        why = "it moves no mass or inertia (add mass below it, lock it with dynamics.lock_joints, or remove it)"
    else:
        masses = model.tree.mass[model.tree.mass > 0]
        why = (f"the {mass:.3g} kg below it has no inertia along its motion here (a point mass on its axis, or "
               f"body masses too far apart for float64: {masses.min():.3g} to {masses.max():.3g} kg); give the "
               f"links below it rotational inertia, or lock it with dynamics.lock_joints")
    return InputError(f"{what}: the mass matrix is singular at joint {name!r}: {why}")
