"""Derivatives of frame kinematics and of the centre of mass (Pinocchio's computeForwardKinematicsDerivatives,
getFrameVelocityDerivatives, getFrameAccelerationDerivatives, getFrameJacobianTimeVariation,
getCenterOfMassVelocityDerivatives).

The forward pass of :mod:`dynamics.rnea_derivatives` (without gravity) gives, in the world frame at the world
origin, per velocity coordinate k of joint j: its axis J_k, and the changes of the subtree's velocity and
acceleration that are not the rigid motion of the subtree, dV_k = ov_p x J_k, dAq_k = oa_p x J_k + ov_p x dV_k,
dAv_k = ov_j x J_k + dV_k.  For a frame on body b and k on b's support (other columns are zero), with ov_b, oa_b
the body's spatial velocity and acceleration:

    d ov_b / dq_k = dV_k + J_k x ov_b,          d ov_b / dv_k = J_k
    d oa_b / dq_k = dAq_k + dV_k x ov_b + J_k x oa_b,   d oa_b / dv_k = dAv_k + J_k x ov_b,   d oa_b / da_k = J_k
    d J_k / dt = ov_j x J_k                                     (the "world" Jacobian's time variation)

In the frame's references (:mod:`dynamics.kinematics`): "world" is the above; "local" applies oX_f^-1 to it
after taking out the frame's own motion J_k x (.) (a rigid motion moves the frame too):
d(oX_f^-1 ov)/dq_k = oX_f^-1 dV_k; "local_world_aligned" is the motion at the frame origin o_f in world axes,
(w, v - o_f x w), whose q derivative also carries the origin's own motion do_f/dq_k = J_k^v + J_k^w x o_f.
Accelerations are spatial (Featherstone's, ``classical=False`` in :func:`dynamics.frame_acceleration`), as
Pinocchio's derivatives.  A frame placement's derivative is the frame Jacobian itself: oM_f(q (+) dq) =
oM_f Exp(J_local dq).

Centre of mass (mass M, c_i the centre of body i, P_j and H_j the subtree sums of m_i dc_i/dt and m_i c_i, m_j
the subtree's mass): d com/dq = Jcom and

    M d(vcom)/dq_k = J_k^w x P_j + m_j dV_k^v + dV_k^w x H_j.

One state per call.
"""

import numpy as np

from . import _core, checks
from ._numba import address, keep_alive, kernel
from .kinematics import frame_placement
from .rnea_derivatives import _forward_step, _work_at

_REFS = ("world", "local", "local_world_aligned")


@kernel
def _kinematics_pass(tree, q, v, a, out):
    """The derivatives' forward pass (no gravity, no force used) into the buffer ``out``."""
    nb, nv = tree.parents.shape[0], tree.S.shape[0]
    ws = _work_at(address(out), 0, nb, nv)[0]
    zero = np.zeros(3)
    for i in range(nb):
        _forward_step(tree, i, q, v, a, zero, np.zeros((0, 6)), ws)
    keep_alive(out)


def _fields(model, q, v, a):
    """The forward pass's arrays by name (numpy views of one buffer)."""
    nb, nv = model.nbodies, model.nv
    sizes = [("oR", (nb, 3, 3)), ("op", (nb, 3)), ("ov", (nb, 6)), ("oa", (nb, 6)), ("mass", (nb,)),
             ("h", (nb, 3)), ("Io", (nb, 3, 3)), ("B", (nb, 3, 3)), ("hf", (nb, 3)), ("F", (nb, 6)),
             ("J", (nv, 6)), ("dV", (nv, 6)), ("dAq", (nv, 6)), ("dAv", (nv, 6))]
    buf = np.empty(_work_at(0, 0, nb, nv)[1])
    _kinematics_pass(model.tree, q, v, a, buf)
    out, o = {}, 0
    for name, shape in sizes:
        n = int(np.prod(shape))
        out[name] = buf[o:o + n].reshape(shape)
        o += n
    return out


def _cross(x, y):
    """Motion cross product x X y of rows (w, v) (..., 6) (either may be one 6-vector)."""
    xw, xv, yw, yv = x[..., :3], x[..., 3:], y[..., :3], y[..., 3:]
    return np.concatenate([np.cross(xw, yw), np.cross(xw, yv) + np.cross(xv, yw)], axis=-1)


def _state(model, q, v, a, frame, reference):
    checks.check_model(model)
    f = checks.frame(model, frame)
    if reference not in _REFS:
        raise checks.InputError(f"reference: expected one of {list(_REFS)}, got {reference!r}")
    q = checks.vector("q", q, model.nq)
    v = checks.vector("v", v, model.nv)
    a = np.zeros(model.nv) if a is None else checks.vector("a", a, model.nv)
    d = _fields(model, q, v, a)
    body = int(model.frame_arrays.body[f])
    support = np.zeros(model.nv, bool)
    j = body
    while j >= 0:
        support[model.v_index[j]:model.v_index[j] + model.nv_joint[j]] = True
        j = int(model.tree.parents[j])
    return f, body, support, d, frame_placement(model, q, f)


def _in_reference(reference, T, X, dX=None):
    """Columns X (nv, 6) of derivatives of a world motion, (w, v), in ``reference``, as (6, nv) [linear;
    angular].  ``dX``: the columns (nv, 6) of the frame's world motion J_k, for "local_world_aligned" (the
    origin's own motion) given with the motion ``m`` differentiated: dX = (J, m)."""
    R, p = T[:3, :3], T[:3, 3]
    w, lin = X[:, :3], X[:, 3:]
    if reference == "world":
        return np.vstack([lin.T, w.T])
    if reference == "local":
        return np.vstack([R.T @ (lin - np.cross(p, w)).T, R.T @ w.T])
    lin = lin - np.cross(p, w)
    if dX is not None:
        J, m = dX
        dp = J[:, 3:] + np.cross(J[:, :3], p)  # the frame origin's velocity along each column
        lin = lin - np.cross(dp, m[:3])
    return np.vstack([lin.T, w.T])


def frame_velocity_derivatives(model, q, v, frame, *, reference="local_world_aligned"):
    """(dv_dq, dv_dv), each (6, nv): the derivatives of frame_velocity(model, q, v, frame, reference=...)
    ([linear; angular]) with respect to q (tangent space) and v (module docstring).  One state."""
    f, body, support, d, T = _state(model, q, v, None, frame, reference)
    s = support[:, None]
    J, dV, ov = d["J"] * s, d["dV"] * s, d["ov"][body]
    if reference == "local":  # the frame's own motion J x ov taken out
        return _in_reference(reference, T, dV), _in_reference(reference, T, J)
    return _in_reference(reference, T, dV + _cross(J, ov), (J, ov)), _in_reference(reference, T, J)


def frame_acceleration_derivatives(model, q, v, a, frame, *, reference="local_world_aligned"):
    """(dv_dq, da_dq, da_dv, da_da), each (6, nv): the derivatives of the frame's velocity and of its spatial
    acceleration (frame_acceleration(..., classical=False)) with respect to q (tangent space), v and a, as
    Pinocchio's getFrameAccelerationDerivatives.  One state."""
    f, body, support, d, T = _state(model, q, v, a, frame, reference)
    s = support[:, None]
    J, dV, ov, oa = d["J"] * s, d["dV"] * s, d["ov"][body], d["oa"][body]
    Av = d["dAv"] * s + _cross(J, ov)
    if reference == "local":  # the frame's own motion J x (.) taken out of the q derivatives
        Vq, Aq = dV, d["dAq"] * s + _cross(dV, ov)
        return tuple(_in_reference(reference, T, X) for X in (Vq, Aq, Av, J))
    Vq = dV + _cross(J, ov)
    Aq = d["dAq"] * s + _cross(dV, ov) + _cross(J, oa)
    return (_in_reference(reference, T, Vq, (J, ov)), _in_reference(reference, T, Aq, (J, oa)),
            _in_reference(reference, T, Av), _in_reference(reference, T, J))


def frame_jacobian_time_variation(model, q, v, frame, *, reference="local_world_aligned"):
    """dJ/dt (6, nv) of frame_jacobian(model, q, frame, reference=...) moving with velocity v (Pinocchio's
    getFrameJacobianTimeVariation): J a + dJ/dt v = d/dt (J v), which is frame_acceleration(...) in
    "local_world_aligned" (classical) and frame_acceleration(..., classical=False) in "local" and "world".  One
    state.  The core's (``core/jacobians.cpp``)."""
    checks.check_model(model)
    f = checks.frame(model, frame)
    if reference not in _REFS:
        raise checks.InputError(f"reference: expected one of {list(_REFS)}, got {reference!r}")
    q = checks.vector("q", q, model.nq)
    v = checks.vector("v", v, model.nv)
    out = np.empty((6, model.nv))
    _core.frame_jacobian_time_variation(model.core, q, v, f, checks.reference(reference), out)
    return out


def center_of_mass_derivatives(model, q, v):
    """(dcom_dq, dvcom_dq), each (3, nv), world frame: the derivatives of center_of_mass(model, q) (= Jcom) and
    of center_of_mass_velocity(model, q, v) with respect to q (tangent space; module docstring).  One state."""
    checks.check_model(model)
    q = checks.vector("q", q, model.nq)
    v = checks.vector("v", v, model.nv)
    d = _fields(model, q, v, np.zeros(model.nv))
    tree, nb = model.tree, model.nbodies
    m = np.asarray(tree.mass, float)
    c = np.array([d["oR"][i] @ (tree.h[i] / m[i] if m[i] > 0 else np.zeros(3)) + d["op"][i] for i in range(nb)])
    cdot = d["ov"][:, 3:] + np.cross(d["ov"][:, :3], c)
    ms, H, P = m.copy(), m[:, None] * c, m[:, None] * cdot
    for i in range(nb - 1, -1, -1):  # subtree sums
        par = int(tree.parents[i])
        if par >= 0:
            ms[par] += ms[i]
            H[par] += H[i]
            P[par] += P[i]
    J, dV = d["J"], d["dV"]
    total = m.sum()
    dcom, dvcom = np.zeros((3, model.nv)), np.zeros((3, model.nv))
    for i in range(nb):
        k = slice(model.v_index[i], model.v_index[i] + model.nv_joint[i])
        dcom[:, k] = (ms[i] * J[k, 3:] + np.cross(J[k, :3], H[i])).T / total
        dvcom[:, k] = (np.cross(J[k, :3], P[i]) + ms[i] * dV[k, 3:] + np.cross(dV[k, :3], H[i])).T / total
    return dcom, dvcom
