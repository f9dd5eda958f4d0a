"""Building a :class:`~.sources.Source` from the user's ``torque`` argument: every input checked here, at the
public entry, with an error that names the argument (``torque.kp``, ``torque.reference.t``, ...)."""

import math
import weakref

import numpy as np

from .. import _core, checks
from ..crba import mass_matrix
from ..errors import InputError
from .registry import register_callable
from .sources import (CALLABLE, COMPUTED_TORQUE, CONSTANT, OPERATIONAL_SPACE, PD, PD_KIND, TABLE_LINEAR,
                      TABLE_ZOH, ZERO, ComputedTorque, OperationalSpace, Source, Table, TaskReference, Target)


def _array(name, x, shape, *, nonneg=False):
    """A finite float64 array of ``shape`` (a fresh C-contiguous copy; a scalar fills a vector shape)."""
    t = type(x)
    if (t is float or t is int) and len(shape) == 1:  # a scalar gain (PD's kp, kd): no array round trips
        x = float(x)
        if not math.isfinite(x):
            raise InputError(f"{name}: contains non-finite values")
        if nonneg and x < 0:
            raise InputError(f"{name}: expected values >= 0")
        a = np.empty(shape)
        a.fill(x)
        return a
    if t is np.ndarray and x.dtype is checks.F64 and x.shape == shape and x.size:  # an array as the source wants it
        a = x.copy()
        if _first_nonfinite(a.reshape(1, -1)) >= 0:
            raise InputError(f"{name}: contains non-finite values")
        if nonneg and (min(a.ravel().tolist()) if a.size <= 64 else a.min()) < 0:
            raise InputError(f"{name}: expected values >= 0")
        return a
    try:
        a = np.array(x, dtype=np.float64)
    except (TypeError, ValueError):
        raise InputError(f"{name}: expected a float array of shape {shape}, got {type(x).__name__}") from None
    if a.ndim == 0 and len(shape) == 1:
        a = np.full(shape, float(a))
    if a.shape != shape:
        raise InputError(f"{name}: expected shape {shape}, got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise InputError(f"{name}: contains non-finite values")
    if nonneg and np.any(a < 0):
        raise InputError(f"{name}: expected values >= 0")
    return np.ascontiguousarray(a)


def _times(name, t):
    t = np.array(t, dtype=np.float64)
    if t.ndim != 1 or t.shape[0] < 1:
        raise InputError(f"{name}: expected shape (N,) with N >= 1, got {t.shape}")
    if not np.all(np.isfinite(t)):
        raise InputError(f"{name}: contains non-finite values")
    if np.any(np.diff(t) <= 0):
        raise InputError(f"{name}: times must be strictly increasing")
    return np.ascontiguousarray(t)


def _read_only(frames):
    """``model.frame_arrays`` with every array a read-only view (a source never writes to its model's arrays)."""
    views = []
    for a in frames:
        v = a.view()
        v.flags.writeable = False
        views.append(v)
    return type(frames)(*views)


_first_nonfinite = _core.first_nonfinite  # the first row of a 2-D float64 array with a nan or inf, -1: none
#: per model, its frames as read-only views (models are immutable: built once, kept while the model lives)
_FRAMES = weakref.WeakKeyDictionary()


def _frames_of(model):
    frames = _FRAMES.get(model)
    if frames is None:
        frames = _FRAMES[model] = _read_only(model.frame_arrays)
    return frames


def _source_for(model):
    """Source(...) with the operational-space fields set to placeholders of the right types, and the model's
    placeholder times (1,), table (1, nv) and q target (nq,) (zeros, read-only, shared: the core copies what it
    keeps); per model, kept while it lives."""
    parts = _SOURCES.get(model)
    if parts is None:
        frames, rows, task_gains, orientation = _frames_of(model), _NO_ROWS, _NO_TASK_GAINS, _IDENTITY

        def build(kind, times, table, gains, qref, slot):
            return Source(kind, times, table, gains, qref, slot, frames, -1, rows, task_gains, orientation, 0.0, None)
        zeros = [np.zeros(1), np.zeros((1, model.nv)), np.zeros(model.nq)]
        for a in zeros:
            a.flags.writeable = False
        parts = _SOURCES[model] = (build, *zeros)
    return parts


#: per model: _source_for's
_SOURCES = weakref.WeakKeyDictionary()
_IDENTITY = np.array([[1.0, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0]])
_NO_ROWS, _NO_TASK_GAINS = np.zeros(0, np.int64), np.zeros((2, 6))
for _a in (_IDENTITY, _NO_ROWS, _NO_TASK_GAINS):
    _a.flags.writeable = False


def _rotations(name, R, N):
    """(N, 3, 3) proper rotations from (N, 3, 3) or one (3, 3)."""
    try:
        R = np.array(R, dtype=np.float64) if R is not None else np.eye(3)
    except (TypeError, ValueError):
        raise InputError(f"{name}: expected ({N}, 3, 3) or (3, 3) rotation matrices, got {type(R).__name__}") from None
    if R.shape == (3, 3):
        R = np.broadcast_to(R, (N, 3, 3))
    R = _array(name, R, (N, 3, 3))
    err = np.abs(R @ R.transpose(0, 2, 1) - np.eye(3)).max(initial=0.0)
    if err > 1e-6 or np.any(np.linalg.det(R) <= 0):
        raise InputError(f"{name}: expected rotation matrices (R R^T = 1, det R = +1), off by {err:.1e}")
    return R


def _operational_space_source(model, spec):
    """The OPERATIONAL_SPACE Source: checks every argument, naming it."""
    nv, nq = model.nv, model.nq
    if model.floating_base:
        raise InputError("torque: OperationalSpace needs a fixed-base model (a floating base is not actuated)")
    try:
        f = checks.frame(model, spec.frame)
        rows = checks.rows(spec.rows) if spec.rows is not None else None
    except InputError as e:
        raise InputError(f"torque.{e}") from None
    if isinstance(spec, Target):
        pos = _array("torque.position", spec.position, (3,))
        ref = TaskReference([0.0], pos[None], orientation=spec.orientation)
        names = dict(t="torque.t", position="torque.position", velocity="torque.velocity",
                     acceleration="torque.acceleration", orientation="torque.orientation")
    else:
        ref = spec.reference
        if isinstance(ref, (tuple, list)) and len(ref) in (2, 3):
            ref = TaskReference(ref[0], ref[1], orientation=ref[2] if len(ref) == 3 else None)
        if not isinstance(ref, TaskReference):
            raise InputError("torque.reference: expected (t, position), (t, position, orientation) or a "
                             f"TaskReference, got {type(spec.reference).__name__}")
        names = {k: "torque.reference." + k for k in ("t", "position", "velocity", "acceleration", "orientation")}
    times = _times(names["t"], ref.t)
    N = times.shape[0]
    p = _array(names["position"], ref.position, (N, 3))
    diff = (lambda x: np.gradient(x, times, axis=0, edge_order=2 if N > 2 else 1)) if N > 1 else np.zeros_like
    pd = diff(p) if ref.velocity is None else _array(names["velocity"], ref.velocity, (N, 3))
    pdd = diff(pd) if ref.acceleration is None else _array(names["acceleration"], ref.acceleration, (N, 3))
    R = _rotations(names["orientation"], ref.orientation, N)
    otab = np.zeros((N, 12))
    otab[:, :9] = R.reshape(N, 9)
    for k in range(N - 1):
        otab[k, 9:] = _core.rotation_log(np.ascontiguousarray(R[k + 1] @ R[k].T))
    if rows is None:
        rows = np.arange(6 if ref.orientation is not None else 3)
    if ref.orientation is None and rows.max() > 2:
        raise InputError(f"torque.rows: the angular rows 3-5 need an orientation reference, got {rows.tolist()}")
    task_gains = np.zeros((2, 6))
    task_gains[0, rows] = _array("torque.kp", spec.kp, (rows.size,), nonneg=True)
    task_gains[1, rows] = _array("torque.kd", spec.kd, (rows.size,), nonneg=True)
    gains = np.zeros((4, nv))
    gains[0] = _array("torque.posture_kp", spec.posture_kp, (nv,), nonneg=True)
    if spec.posture is None and np.any(gains[0] > 0):
        raise InputError("torque.posture: required (shape (nq,)) when posture_kp > 0")
    qref = model.neutral() if spec.posture is None else _array("torque.posture", spec.posture, (nq,))
    if spec.posture_kd is not None:
        gains[1] = _array("torque.posture_kd", spec.posture_kd, (nv,), nonneg=True)
    elif spec.posture is not None:
        gains[1] = 2.0 * np.sqrt(gains[0] * np.diag(mass_matrix(model, qref)))
    damping = checks.real_number("torque.damping", spec.damping, lo=0.0)
    return Source(OPERATIONAL_SPACE, times, np.ascontiguousarray(np.concatenate([p, pd, pdd], 1)), gains, qref,
                  -1, _frames_of(model), f, rows.astype(np.int64), task_gains, otab, float(damping), None)


def make_source(model, torque):
    """The :class:`Source` for the ``torque`` argument of :func:`dynamics.simulate` (the core's, made of it:
    :func:`dynamics.simulation.native.core_source`)."""
    nv, nq = model.nv, model.nq
    source, empty_t, empty_tab, qref = _source_for(model)
    gains = np.zeros((4, nv))
    if torque is None:
        return source(ZERO, empty_t, empty_tab, gains, qref, -1)
    if isinstance(torque, Table):
        times = _times("torque.t", torque.t)
        tab = _array("torque.tau", torque.tau, (times.shape[0], nv))
        if torque.hold not in ("linear", "zoh"):
            raise InputError(f"torque.hold: expected 'linear' or 'zoh', got {torque.hold!r}")
        return source(TABLE_LINEAR if torque.hold == "linear" else TABLE_ZOH, times, tab, gains, qref, -1)
    if isinstance(torque, PD):
        qref = _array("torque.q_target", torque.q_target, (nq,))
        gains[0] = _array("torque.kp", torque.kp, (nv,), nonneg=True)
        gains[1] = _array("torque.kd", torque.kd, (nv,), nonneg=True)
        if torque.v_target is not None:
            gains[2] = _array("torque.v_target", torque.v_target, (nv,))
        if torque.tau_ff is not None:
            gains[3] = _array("torque.tau_ff", torque.tau_ff, (nv,))
        return source(PD_KIND, empty_t, empty_tab, gains, qref, -1)
    if isinstance(torque, ComputedTorque):
        if model.floating_base or nq != nv:
            raise InputError("torque: ComputedTorque needs a fixed-base model with 1-dof joints (nq == nv)")
        times = _times("torque.t", torque.t)
        N = times.shape[0]
        tab = np.concatenate([_array("torque.q", torque.q, (N, nq)), _array("torque.v", torque.v, (N, nv)),
                              _array("torque.a", torque.a, (N, nv))], axis=1)
        gains[0] = _array("torque.kp", torque.kp, (nv,), nonneg=True)
        gains[1] = _array("torque.kd", torque.kd, (nv,), nonneg=True)
        return source(COMPUTED_TORQUE, times, np.ascontiguousarray(tab), gains, qref, -1)
    if isinstance(torque, OperationalSpace):
        return _operational_space_source(model, torque)
    if callable(torque):
        return source(CALLABLE, empty_t, empty_tab, gains, qref, register_callable(torque, nv))
    try:
        gains[0] = _array("torque", torque, (nv,))
    except InputError as e:
        raise InputError(f"{e} (torque: expected None, an (nv,) = ({nv},) array, a Table, PD, ComputedTorque "
                         "or a callable f(t, q, v) -> tau)") from None
    return source(CONSTANT, empty_t, empty_tab, gains, qref, -1)
