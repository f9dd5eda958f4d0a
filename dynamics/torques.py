"""Joint torque sources for :func:`dynamics.simulate`, and the passive joint torques of the model.

A torque source turns (t, q, v) into the applied joint torques tau (nv,).  Every source except a Python
callable is compiled: it is stored as one tuple of arrays (``Source``) of the same numba type for every
kind, and :func:`torque_eval` evaluates it inside the compiled integration loop, compiled for its kind alone
(the kind's tag, :func:`kind_tag`, travels with it as a type).

=====================  ========================================================================================
``torque=`` argument   tau(t, q, v)
=====================  ========================================================================================
``None``               0
array (nv,)            the constant vector
``Table(t, tau)``      piecewise linear in t through the rows of tau (N, nv); ``hold="zoh"``: tau[k] on
                       [t_k, t_k+1).  Before t_0 / after t_N-1 the first / last row.
``PD(q_target, kp,     kp (q_target - q) + kd (v_target - v) + tau_ff; the position error is the tangent
kd)``                  vector from q to q_target (:func:`dynamics.integrate._difference`), so it is also
                       defined for a free-flyer (whose gains are zero by default unless given per dof).
``ComputedTorque(t,    M(q) a* + h(q, v) - tau_passive(q, v) with a* = a_ref + kd (v_ref - v) + kp (q_ref - q)
q, v, a, kp, kd)``     (inverse dynamics, the RNEA), so the closed loop is e'' + kd e' + kp e = 0 exactly for the
                       model.  The reference is a table of samples (t_k, q_k, v_k, a_k) interpolated by quintic
                       Hermite polynomials, which are C2 and consistent (v_ref = q_ref', a_ref = v_ref').
``OperationalSpace(    operational-space control of a frame's position (and orientation) along a reference
frame, reference,      trajectory: tau = J^T (Lambda xdd* + mu + p) + N tau_0 with a null-space posture task
kp, kd)``, ``Target``  (:mod:`dynamics.operational_space`); ``Target`` holds a fixed pose.
callable f(t, q, v)    called from the compiled loop through ``numba.objmode`` (one Python call per
                       right-hand-side evaluation; everything else stays compiled).
=====================  ========================================================================================

Passive joint torques (:func:`passive_torques`), always added by the simulator:

* viscous damping ``-d v`` (URDF ``<dynamics damping>``);
* Coulomb friction ``-F tanh(v / eps)`` (URDF ``<dynamics friction>``), regularised with the velocity scale
  ``eps`` (``friction_eps``, default 1e-3 rad/s or m/s): exact Coulomb for |v| >> eps, a stiff viscous law of
  slope F/eps near rest (so tiny eps makes the problem stiff);
* with ``limits="spring"``, a Hunt-Crossley spring-damper at the URDF position limits, penetration
  x = lower - q (or q - upper) > 0:  ``tau = +-max(0, k x + b x x')`` (stiffness k, damping b*x that vanishes
  at contact, so the force is continuous).
"""

import warnings
from typing import NamedTuple

import numpy as np
from numba import objmode, typeof, types
from numba.core.errors import NumbaWarning
from numba.extending import intrinsic, overload

from . import checks
from .errors import InputError
from ._numba import (JIT_OPTIONS, borrowing_kernel, call_address, copy_into, deref, gil_kernel, inline_kernel, kernel,
                     native_address, owned_pack)
from .configuration import _difference
from .crba import mass_matrix
from .operational_space import operational_space_into
from .operational_space import _workspace as operational_space_workspace
from .rnea import _rnea_into
from .rnea import _workspace as rnea_workspace
from .spatial import _rotation_log


# The objmode block for Python callables re-takes the GIL by design; numba warns about it at compile time.
warnings.filterwarnings("ignore", message="Code running in object mode won't allow parallel execution",
                        category=NumbaWarning)

ZERO, CONSTANT, TABLE_LINEAR, TABLE_ZOH, PD_KIND, COMPUTED_TORQUE, CALLABLE, OPERATIONAL_SPACE = range(8)
KIND_NAMES = ("zero", "constant", "table_linear", "table_zoh", "pd", "computed_torque", "callable",
              "operational_space")


class Source(NamedTuple):
    """Compiled form of a torque source: one numba type for every kind except the operational space, whose
    workspace ``ws`` is None in the others (the operational-space workspace is large).  Which kind's
    evaluation is compiled is told by its tag (:func:`kind_tag`, in :class:`SourceCall`)."""

    kind: int
    times: np.ndarray  # (N,) table or reference times
    table: np.ndarray  # (N, m): torques (m = nv) or reference [q, v, a] (m = 3 nv) or [p, pdot, pddot] (m = 9)
    gains: np.ndarray  # (4, nv): rows are kind-dependent (constant tau | kp, kd, v_target, tau_ff)
    qref: np.ndarray  # (nq,) PD target configuration, operational space: posture
    slot: int  # callable registry slot
    # operational space only (the other kinds carry harmless placeholders of the same types)
    frames: object  # model.frame_arrays
    frame: int  # the controlled frame, -1 for the other kinds
    rows: np.ndarray  # (r,) int64: task rows of [linear; angular]
    task_gains: np.ndarray  # (2, 6): Kp, Kd per task row
    orientation: np.ndarray  # (N, 12): reference orientation R_k (9) and psi_k = log(R_k+1 R_k^T) (3)
    damping: float  # added to the diagonal of J M^-1 J^T
    ws: object  # operational_space.workspace (None for the other kinds): scratch, so one Source serves one
    #             simulation at a time (as it does)


class Passive(NamedTuple):
    """Model and simulation parameters of the passive joint torques (numba-friendly)."""

    damping: np.ndarray  # (nv,)
    friction: np.ndarray  # (nv,)
    friction_eps: float
    limits: int  # 0 none, 1 spring
    lower: np.ndarray  # (nv,)
    upper: np.ndarray  # (nv,)
    qpos: np.ndarray  # (nv,) int64: q index of a 1-dof coordinate, -1 for free-joint coordinates
    k_limit: float
    b_limit: float
    gravity: np.ndarray  # (3,)
    f_ext: np.ndarray  # (0, 6)


# ---------------------------------------------------------------------------------------------------
# user-facing descriptions
class Table:
    """Tabulated torques: times (N,) strictly increasing, tau (N, nv); hold "linear" or "zoh"."""

    def __init__(self, t, tau, hold="linear"):
        self.t, self.tau, self.hold = t, tau, hold


class PD:
    """PD control to a target posture: tau = kp (q_target - q) + kd (v_target - v) + tau_ff.

    kp, kd: scalars or (nv,) arrays (>= 0); v_target, tau_ff: (nv,) arrays, default zero.
    """

    def __init__(self, q_target, kp, kd, v_target=None, tau_ff=None):
        self.q_target, self.kp, self.kd, self.v_target, self.tau_ff = q_target, kp, kd, v_target, tau_ff


class ComputedTorque:
    """Computed-torque tracking of a reference (t (N,), q (N, nq), v (N, nv), a (N, nv)); fixed base only.

    kp, kd: scalars or (nv,) arrays (>= 0).  The reference is interpolated by quintic Hermite polynomials.
    """

    def __init__(self, t, q, v, a, kp, kd):
        self.t, self.q, self.v, self.a, self.kp, self.kd = t, q, v, a, kp, kd


class OperationalSpace:
    """Operational-space control of ``frame`` along ``reference`` (:mod:`dynamics.operational_space`).

    reference: ``(t, position)`` or ``(t, position, orientation)``, or a :class:`TaskReference` (which can also
    give the velocities and accelerations): t (N,) strictly increasing, position (N, 3) of the frame origin in
    the world, orientation (N, 3, 3) or one (3, 3) rotation of the frame's axes in the world.
    rows: the task rows of [x, y, z, wx, wy, wz] (world axes), default the 3 position rows, or all 6 with an
    orientation.  kp, kd: >= 0, scalars or one per task row (task-space acceleration gains, 1/s^2 and 1/s).
    posture (nq,): the null-space posture, pulled by the joint torques posture_kp (posture - q) - posture_kd v
    projected into the dynamically consistent null space (posture_kp in N m/rad, scalar or (nv,));
    posture_kd defaults to 2 sqrt(posture_kp M_ii(posture)) (each joint critically damped on its own inertia).
    Before the first and after the last sample the reference holds its end position at rest.
    damping >= 0: added to the diagonal of J M^-1 J^T (robust near singularities, at the cost of exact
    tracking).  Fixed base only.
    """

    def __init__(self, frame, reference, kp, kd, posture=None, posture_kp=0.0, posture_kd=None, rows=None,
                 damping=0.0):
        self.frame, self.reference, self.kp, self.kd = frame, reference, kp, kd
        self.posture, self.posture_kp, self.posture_kd = posture, posture_kp, posture_kd
        self.rows, self.damping = rows, damping


class TaskReference:
    """A task-space reference: t (N,), position (N, 3), optional velocity and acceleration (N, 3) (central
    finite differences of the positions when absent) and orientation (N, 3, 3) or (3, 3).  Positions are
    interpolated by quintic Hermite polynomials through (position, velocity, acceleration); the orientation
    along the geodesic between samples at constant angular velocity."""

    def __init__(self, t, position, velocity=None, acceleration=None, orientation=None):
        self.t, self.position, self.velocity, self.acceleration = t, position, velocity, acceleration
        self.orientation = orientation


class Target(OperationalSpace):
    """Operational-space regulation of ``frame`` to a fixed position (3,) and, if given, orientation (3, 3):
    the constant-reference form of :class:`OperationalSpace` (same keyword arguments)."""

    def __init__(self, frame, position, orientation=None, *, kp, kd, **kwargs):
        super().__init__(frame, None, kp, kd, **kwargs)
        self.position, self.orientation = position, orientation


# ---------------------------------------------------------------------------------------------------
# callables: a registry the compiled code reaches through objmode
_REGISTRY = {}
_NEXT_SLOT = [0]


def register_callable(fn, nv):
    """Store fn and return its slot; release it with :func:`release_callable`."""
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


# ---------------------------------------------------------------------------------------------------
# compiled evaluation
@kernel
def _segment(times, t):
    """k with times[k] <= t < times[k+1], clipped to [0, N-2] (N >= 2)."""
    k = np.searchsorted(times, t, side="right") - 1
    if k < 0:
        k = 0
    if k > times.shape[0] - 2:
        k = times.shape[0] - 2
    return k


@kernel
def reference_at(times, table, nv, t, q, v, a):
    """Quintic Hermite interpolation of the reference [q, v, a] rows of ``table`` at time t (clamped)."""
    N = times.shape[0]
    if N == 1 or t <= times[0] or t >= times[N - 1]:
        k = 0 if (N == 1 or t <= times[0]) else N - 1
        for i in range(nv):
            q[i] = table[k, i]
            v[i] = table[k, nv + i]
            a[i] = table[k, 2 * nv + i]
        return
    k = _segment(times, t)
    h = times[k + 1] - times[k]
    s = (t - times[k]) / h
    s2 = s * s
    s3 = s2 * s
    s4 = s3 * s
    s5 = s4 * s
    H = (1 - 10 * s3 + 15 * s4 - 6 * s5, s - 6 * s3 + 8 * s4 - 3 * s5, 0.5 * s2 - 1.5 * s3 + 1.5 * s4 - 0.5 * s5,
         0.5 * s3 - s4 + 0.5 * s5, -4 * s3 + 7 * s4 - 3 * s5, 10 * s3 - 15 * s4 + 6 * s5)
    D = (-30 * s2 + 60 * s3 - 30 * s4, 1 - 18 * s2 + 32 * s3 - 15 * s4, s - 4.5 * s2 + 6 * s3 - 2.5 * s4,
         1.5 * s2 - 4 * s3 + 2.5 * s4, -12 * s2 + 28 * s3 - 15 * s4, 30 * s2 - 60 * s3 + 30 * s4)
    DD = (-60 * s + 180 * s2 - 120 * s3, -36 * s + 96 * s2 - 60 * s3, 1 - 9 * s + 18 * s2 - 10 * s3,
          3 * s - 12 * s2 + 10 * s3, -24 * s + 84 * s2 - 60 * s3, 60 * s - 180 * s2 + 120 * s3)
    for i in range(nv):
        c0 = table[k, i]
        c1 = h * table[k, nv + i]
        c2 = h * h * table[k, 2 * nv + i]
        c3 = h * h * table[k + 1, 2 * nv + i]
        c4 = h * table[k + 1, nv + i]
        c5 = table[k + 1, i]
        q[i] = H[0] * c0 + H[1] * c1 + H[2] * c2 + H[3] * c3 + H[4] * c4 + H[5] * c5
        v[i] = (D[0] * c0 + D[1] * c1 + D[2] * c2 + D[3] * c3 + D[4] * c4 + D[5] * c5) / h
        a[i] = (DD[0] * c0 + DD[1] * c1 + DD[2] * c2 + DD[3] * c3 + DD[4] * c4 + DD[5] * c5) / (h * h)


@inline_kernel
def passive_torques(ps, q, v, out):
    """out = damping + friction + limit-spring torques (module docstring)."""
    for k in range(v.shape[0]):
        tq = -ps.damping[k] * v[k]
        if ps.friction[k] != 0.0:
            tq -= ps.friction[k] * np.tanh(v[k] / ps.friction_eps)
        if ps.limits == 1 and ps.qpos[k] >= 0:
            x = q[ps.qpos[k]]
            if x < ps.lower[k]:
                pen = ps.lower[k] - x
                tq += max(0.0, ps.k_limit * pen - ps.b_limit * pen * v[k])
            elif x > ps.upper[k]:
                pen = x - ps.upper[k]
                tq -= max(0.0, ps.k_limit * pen + ps.b_limit * pen * v[k])
        out[k] = tq


@gil_kernel  # not nogil: the objmode block takes the GIL anyway
def _torque_callable(slot, t, q, v, tau):
    with objmode():
        _call_torque(slot, t, q, v, tau)


def _computed_torque_eval(tag, src, tree, ps, t, q, v, ws, tau):
    """The computed torque (module docstring); compiled as :func:`torque_eval` for this kind."""
    nv = v.shape[0]
    qr = ws[1][0]
    vr = ws[1][1]
    ar = ws[1][2]
    reference_at(src.times, src.table, nv, t, qr, vr, ar)
    for i in range(nv):
        ar[i] += src.gains[1, i] * (vr[i] - v[i]) + src.gains[0, i] * (qr[i] - q[i])
    _rnea_into(tree, q, v, ar, ps.gravity, ps.f_ext, ws[0], tau)
    pas = ws[1][3]
    passive_torques(ps, q, v, pas)
    for i in range(nv):
        tau[i] -= pas[i]


def _operational_space_eval(tag, src, tree, ps, t, q, v, ws, tau):
    """The operational-space torques; compiled as :func:`torque_eval` for this kind."""
    x_ref = np.empty((3, 3))
    reference_at(src.times, src.table, 3, t, x_ref[0], x_ref[1], x_ref[2])
    if t < src.times[0] or t > src.times[-1]:  # hold the end position at rest
        x_ref[1:] = 0.0
    pas = ws[1][3]
    passive_torques(ps, q, v, pas)
    operational_space_into(src, tree, ps.gravity, ps.f_ext, t, q, v, x_ref, pas, ws[0], tau)


def _zero_torques(tag, src, tree, ps, t, q, v, ws, tau):
    for i in range(tau.shape[0]):
        tau[i] = 0.0


def _constant_torques(tag, src, tree, ps, t, q, v, ws, tau):
    copy_into(tau, src.gains[0])


def _table_torques(tag, src, tree, ps, t, q, v, ws, tau):
    """Linear or zero-order-hold interpolation of the rows of src.table (src.kind says which)."""
    times = src.times
    N = times.shape[0]
    if N == 1 or t <= times[0]:
        copy_into(tau, src.table[0])
    elif t >= times[N - 1]:
        copy_into(tau, src.table[N - 1])
    else:
        k = _segment(times, t)
        if src.kind == TABLE_ZOH:
            copy_into(tau, src.table[k])
        else:
            s = (t - times[k]) / (times[k + 1] - times[k])
            for i in range(tau.shape[0]):
                tau[i] = (1 - s) * src.table[k, i] + s * src.table[k + 1, i]


def _pd_torques(tag, src, tree, ps, t, q, v, ws, tau):
    e = ws[1][0]
    _difference(tree, q, src.qref, e)
    for i in range(tau.shape[0]):
        tau[i] = src.gains[0, i] * e[i] + src.gains[1, i] * (src.gains[2, i] - v[i]) + src.gains[3, i]


def _callable_torques(tag, src, tree, ps, t, q, v, ws, tau):
    _torque_callable(src.slot, t, q, v, tau)


class ZeroKind(NamedTuple):
    """The numba type of a source of kind ZERO (:func:`kind_tag`)."""


class ConstantKind(NamedTuple):
    """... of kind CONSTANT."""


class TableKind(NamedTuple):
    """... of kind TABLE_LINEAR or TABLE_ZOH."""


class PDKind(NamedTuple):
    """... of kind PD_KIND."""


class ComputedTorqueKind(NamedTuple):
    """... of kind COMPUTED_TORQUE."""


class CallableKind(NamedTuple):
    """... of kind CALLABLE."""


class OperationalSpaceKind(NamedTuple):
    """... of kind OPERATIONAL_SPACE."""


#: per kind: its tag (an empty NamedTuple class: a numba type with no data) and the function that evaluates it
_KINDS = {ZERO: (ZeroKind, _zero_torques), CONSTANT: (ConstantKind, _constant_torques),
          TABLE_LINEAR: (TableKind, _table_torques), TABLE_ZOH: (TableKind, _table_torques),
          PD_KIND: (PDKind, _pd_torques), COMPUTED_TORQUE: (ComputedTorqueKind, _computed_torque_eval),
          CALLABLE: (CallableKind, _callable_torques),
          OPERATIONAL_SPACE: (OperationalSpaceKind, _operational_space_eval)}
_EVAL = {tag: fn for tag, fn in _KINDS.values()}


def kind_tag(kind):
    """The tag of a source kind: passed with the source (:class:`SourceCall`), its numba type selects the one
    evaluation :func:`torque_eval` compiles."""
    return _KINDS[kind][0]()


def torque_eval(tag, src, tree, ps, t, q, v, ws, tau):
    """tau = the source's applied torques at (t, q, v).  ws: (rnea workspace, 4 scratch (nv,) rows).  ``tag``
    (:func:`kind_tag`) names src's kind at compile time (compiled code only): a source compiles only its own
    kind's evaluation (not the PD's configuration difference, the tables' search, the callable's objmode
    block, the computed torque's RNEA or the operational-space controller of the others)."""
    raise NotImplementedError


@overload(torque_eval, jit_options=JIT_OPTIONS)
def _ov_torque_eval(tag, src, tree, ps, t, q, v, ws, tau):
    return _EVAL[tag.instance_class]


# ---------------------------------------------------------------------------------------------------
# a source behind an address: compiled once per source type, called by the simulation's rhs and sample writer
class SourceCall(NamedTuple):
    """What :func:`torque_eval` reads besides (t, q, v): packed by :func:`bind_source`."""

    src: object  # Source
    tree: object  # the model's Tree
    ps: object  # Passive
    ws: tuple  # source_workspace(...)
    tag: object  # kind_tag(src.kind): its type selects the evaluation compiled


#: the arguments after the pointer of :func:`source_call`: t, q, v, tau
_VEC = types.float64[::1]
SOURCE_ARGS = (types.float64, _VEC, _VEC, _VEC)
_SOURCE_ADDRESSES = {}  # SourceCall type -> address of source_call compiled for a pointer to it (this process)


@borrowing_kernel
def source_call(c, t, q, v, tau):
    """tau = the torques of the source packed in c (a SourceCall or a pointer to one) at (t, q, v).  Without
    reference counting (its arrays are the packed, borrowed SourceCall's and the caller's: 0.3 CPU s less to
    compile for a zero torque); the evaluations (:func:`torque_eval`) keep it, since some allocate."""
    c = deref(c)
    torque_eval(c.tag, c.src, c.tree, c.ps, t, q, v, c.ws, tau)


def source_signature(call):
    """The signature :func:`source_call` is compiled for to serve ``call`` (a SourceCall) by address."""
    return types.none(types.CPointer(typeof(call)), *SOURCE_ARGS)


def bind_source(src, tree, ps, ws):
    """(address of :func:`source_call` compiled, once per source type and kind, for a pointer to the SourceCall, and the
    packed SourceCall in a buffer that keeps it alive): the two arguments of :func:`call_source`.  So the
    source's code (the operational-space controller: M^-1, a Jacobian, a task solve) is optimised once, in
    source_call, and not again in every function that evaluates it."""
    call = SourceCall(src, tree, ps, ws, kind_tag(src.kind))
    sig = source_signature(call)
    key = sig.args[0]
    if key not in _SOURCE_ADDRESSES:
        _SOURCE_ADDRESSES[key] = native_address(source_call, sig)
    return _SOURCE_ADDRESSES[key], owned_pack(call)


@intrinsic
def call_source(typingctx, fn, buf, t, q, v, tau):
    """``source_call(buf's SourceCall, t, q, v, tau)`` through the address fn (:func:`bind_source`)."""
    callee = types.none(types.voidptr, *SOURCE_ARGS)
    argtys = (fn, buf, t, q, v, tau)

    def codegen(context, builder, sig, args):
        data = context.make_array(argtys[1])(context, builder, args[1]).data
        vals = [builder.bitcast(data, context.get_value_type(types.voidptr))]
        vals += [context.cast(builder, a, ty, want) for a, ty, want in zip(args[2:], argtys[2:], SOURCE_ARGS)]
        call_address(context, builder, context.cast(builder, args[0], fn, types.int64), callee, vals)
        return context.get_dummy_value()
    return types.none(*argtys), codegen


# ---------------------------------------------------------------------------------------------------
# building a Source from the user's argument (input checks live here, at the public entry)
def _array(name, x, shape, *, nonneg=False):
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


def _source_for(model):
    """Source(...) with the operational-space fields set to placeholders of the right types."""
    frames, rows, task_gains, orientation = model.frame_arrays, np.zeros(0, np.int64), np.zeros((2, 6)), _IDENTITY

    def build(kind, times, table, gains, qref, slot):
        return Source(kind, times, table, gains, qref, slot, frames, -1, rows, task_gains, orientation, 0.0, None)
    return build


_IDENTITY = np.array([[1.0, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0]])


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
        otab[k, 9:] = _rotation_log(tuple((R[k + 1] @ R[k].T).ravel()))
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
    qref = np.zeros(nq) if spec.posture is None else _array("torque.posture", spec.posture, (nq,))
    if spec.posture_kd is not None:
        gains[1] = _array("torque.posture_kd", spec.posture_kd, (nv,), nonneg=True)
    elif spec.posture is not None:
        gains[1] = 2.0 * np.sqrt(gains[0] * np.diag(mass_matrix(model, qref)))
    damping = checks.real_number("torque.damping", spec.damping, lo=0.0)
    return Source(OPERATIONAL_SPACE, times, np.ascontiguousarray(np.concatenate([p, pd, pdd], 1)), gains, qref,
                  -1, model.frame_arrays, f, rows.astype(np.int64), task_gains, otab, float(damping),
                  operational_space_workspace(model.tree.parents.shape[0], nv, nq))


def source_workspace(source, nb, nv):
    """Scratch for :func:`torque_eval`: (an RNEA workspace, 4 (nv,) rows).  The RNEA workspace is None unless
    the source runs the RNEA (computed torque, operational space)."""
    uses_rnea = source.kind in (COMPUTED_TORQUE, OPERATIONAL_SPACE)
    return (rnea_workspace(nb) if uses_rnea else None, np.empty((4, nv)))


def make_source(model, torque):
    """The compiled :class:`Source` for the ``torque`` argument of :func:`dynamics.simulate`."""
    nv, nq = model.nv, model.nq
    empty_t = np.zeros(1)
    empty_tab = np.zeros((1, nv))
    gains = np.zeros((4, nv))
    qref = np.zeros(nq)
    source = _source_for(model)
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
