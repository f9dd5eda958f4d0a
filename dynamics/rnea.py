"""Inverse dynamics by the Recursive Newton-Euler Algorithm (Featherstone 2008, sec. 5.3, Table 5.1).

    tau = M(q) a + C(q, v) v + g(q) - sum_i J_i^T f_ext_i

Body-frame formulation.  Gravity enters as a fictitious upward acceleration of the world, a_0 = (0, -g).
Forward pass, for each body i with parent p and joint velocity v_J = S_i qd_i:

    v_i = X_i v_p + S_i qd_i
    a_i = X_i a_p + S_i qdd_i + v_i x (S_i qd_i)
    f_i = I_i a_i + v_i x* I_i v_i - f_ext_i

Backward pass:  tau_i = S_i^T f_i ,  f_p += X_i^T f_i .
"""

import numpy as np

from . import checks
from ._numba import (PACKED, VECTOR, Kernel, PythonFunction, inline_kernel, keep_alive, kernel, py_array, py_status,
                     scratch, view)
from .checks import DONE, GENERAL, config_ok, nonzero, py_packed, py_result, py_state, vector_ok
from .model import unpack
from .parallel import run_chunks
from .joints import joint_motion, joint_transform, project_force
from .spatial import (add, cross, cross_force, cross_motion, force_to_parent, inertia_times, load3, load33,
                      motion_to_child, rot, rotT, scale, store3, store33)


@kernel
def workspace(nb):
    """Scratch for one state, owned (the caller may keep it): the same arrays as :func:`workspace_in`."""
    buf = np.empty(nb * 30)
    return (buf[:9 * nb].reshape((nb, 3, 3)), buf[9 * nb:12 * nb].reshape((nb, 3)),
            buf[12 * nb:15 * nb].reshape((nb, 3)), buf[15 * nb:18 * nb].reshape((nb, 3)),
            buf[18 * nb:21 * nb].reshape((nb, 3)), buf[21 * nb:24 * nb].reshape((nb, 3)),
            buf[24 * nb:27 * nb].reshape((nb, 3)), buf[27 * nb:30 * nb].reshape((nb, 3)))


@inline_kernel
def workspace_in(buf, nb):
    """Scratch for one state, borrowed from ``buf`` (30 nb floats, kept alive by the caller): poses (R, p),
    velocities (w, v), accelerations (aw, av), forces (n, f)."""
    return (view(buf, 0, (nb, 3, 3)), view(buf, 9 * nb, (nb, 3)), view(buf, 12 * nb, (nb, 3)),
            view(buf, 15 * nb, (nb, 3)), view(buf, 18 * nb, (nb, 3)), view(buf, 21 * nb, (nb, 3)),
            view(buf, 24 * nb, (nb, 3)), view(buf, 27 * nb, (nb, 3)))


@inline_kernel
def rnea_terms(tree, q, v, a, gravity, f_ext, ws, tau, with_v, with_a):
    """RNEA for one state into ``tau``; ``f_ext`` is (nb, 6) [force, torque] per body or (0, 6).

    ``with_v=False`` (v is zero) skips the velocity pass and every velocity-product term; ``with_a=False``
    (a is zero) skips the joint accelerations: the caller promises those inputs are zero.
    """
    parents, mass, hs, Ios = tree.parents, tree.mass, tree.h, tree.Io
    Rs, ps, ws_, vs, aws, avs, ns, fs = ws
    zero = (0.0, 0.0, 0.0)
    a0 = (-gravity[0], -gravity[1], -gravity[2])  # the world accelerates up: a_0 = (0, -g)
    nb = parents.shape[0]
    for i in range(nb):
        R, p = joint_transform(tree, i, q)
        par = parents[i]
        if par < 0:
            aw, al = motion_to_child(R, p, zero, a0)
        else:
            aw, al = motion_to_child(R, p, load3(aws, par), load3(avs, par))
        if with_a:
            sw, sv = joint_motion(tree, i, a)
            aw, al = add(aw, sw), add(al, sv)
        m, h, Io = mass[i], load3(hs, i), load33(Ios, i)
        if with_v:
            if par < 0:
                w, vl = motion_to_child(R, p, zero, zero)
            else:
                w, vl = motion_to_child(R, p, load3(ws_, par), load3(vs, par))
            wJ, vJ = joint_motion(tree, i, v)
            w, vl = add(w, wJ), add(vl, vJ)
            store3(ws_, i, w)
            store3(vs, i, vl)
            cw, cv = cross_motion(w, vl, wJ, vJ)
            aw, al = add(aw, cw), add(al, cv)
        # f_i = I a + v x* I v - f_ext
        n, f = inertia_times(m, h, Io, aw, al)
        if with_v:
            hn, hf = inertia_times(m, h, Io, w, vl)
            bn, bf = cross_force(w, vl, hn, hf)
            n, f = add(n, bn), add(f, bf)
        if f_ext.shape[0] > 0:
            n = (n[0] - f_ext[i, 3], n[1] - f_ext[i, 4], n[2] - f_ext[i, 5])
            f = (f[0] - f_ext[i, 0], f[1] - f_ext[i, 1], f[2] - f_ext[i, 2])
        store33(Rs, i, R)
        store3(ps, i, p)
        store3(aws, i, aw)
        store3(avs, i, al)
        store3(ns, i, n)
        store3(fs, i, f)
    for i in range(nb - 1, -1, -1):
        n, f = load3(ns, i), load3(fs, i)
        project_force(tree, i, n, f, tau)
        par = parents[i]
        if par >= 0:
            pn, pf = force_to_parent(load33(Rs, i), load3(ps, i), n, f)
            store3(ns, par, add(load3(ns, par), pn))
            store3(fs, par, add(load3(fs, par), pf))


@inline_kernel
def gravity_into(tree, q, gravity, ws, tau):
    """g(q): RNEA at v = a = 0, where each body's force reduces to the weight of its subtree.

    With a_0 = (0, -g) every a_i = (0, -g_i), g_i = R_i^T g_p, so f_i summed over the subtree of i is
    (-H_i x g_i, -M_i g_i) with M_i, H_i the subtree's mass and first moment in frame i:
    tau_i = S_i^T (-H_i x g_i, -M_i g_i).  No inertia tensor and no velocity enters.
    """
    parents, mass, hs = tree.parents, tree.mass, tree.h
    Rs, ps, gs, Hs = ws[0], ws[1], ws[2], ws[3]
    Ms = ws[4][:, 0]
    nb = parents.shape[0]
    for i in range(nb):
        R, p = joint_transform(tree, i, q)
        par = parents[i]
        g = rotT(R, (gravity[0], gravity[1], gravity[2]) if par < 0 else load3(gs, par))
        store33(Rs, i, R)
        store3(ps, i, p)
        store3(gs, i, g)
        store3(Hs, i, load3(hs, i))
        Ms[i] = mass[i]
    for i in range(nb - 1, -1, -1):
        H, M, g = load3(Hs, i), Ms[i], load3(gs, i)
        project_force(tree, i, cross(g, H), scale(-M, g), tau)  # -H x g = g x H
        par = parents[i]
        if par >= 0:
            store3(Hs, par, add(load3(Hs, par), add(rot(load33(Rs, i), H), scale(M, load3(ps, i)))))
            Ms[par] += M


@kernel
def gravity_batch(tree, Q, gravity, out):
    ws = workspace(tree.parents.shape[0])
    for b in range(Q.shape[0]):
        gravity_into(tree, Q[b], gravity, ws, out[b])


@kernel
def rnea_into(tree, q, v, a, gravity, f_ext, ws, tau):
    """RNEA for one state into ``tau`` with every term."""
    rnea_terms(tree, q, v, a, gravity, f_ext, ws, tau, True, True)


@kernel
def rnea_batch(tree, Q, V, A, F, gravity, with_v, with_a, out):
    """Rows of ``out`` = RNEA of the rows of Q, V, A (V or A may have one row when unused); F is
    (1 or B, nb or 0, 6)."""
    ws = workspace(tree.parents.shape[0])
    lf, lv, la = F.shape[0] - 1, V.shape[0] - 1, A.shape[0] - 1
    for b in range(Q.shape[0]):
        rnea_terms(tree, Q[b], V[min(b, lv)], A[min(b, la)], gravity, F[min(b, lf)], ws, out[b], with_v, with_a)


# -- one state from Python: inputs checked inside the call (status codes of dynamics.checks) ----------------
@kernel
def rnea_single(packed, q, v, a, tau):
    tree, gravity, nq = unpack(packed)
    nb, nv = tree.parents.shape[0], tree.S.shape[0]
    if not (config_ok(tree, nq, q) and vector_ok(v, nv) and vector_ok(a, nv) and tau.shape[0] == nv):
        return GENERAL
    buf = scratch(30 * nb)
    rnea_terms(tree, q, v, a, gravity, view(buf, 0, (0, 6)), workspace_in(buf, nb), tau, nonzero(v), nonzero(a))
    keep_alive(buf)
    return DONE


@kernel
def bias_single(packed, q, v, tau):
    tree, gravity, nq = unpack(packed)
    nb, nv = tree.parents.shape[0], tree.S.shape[0]
    if not (config_ok(tree, nq, q) and vector_ok(v, nv) and tau.shape[0] == nv):
        return GENERAL
    buf = scratch(30 * nb)
    rnea_terms(tree, q, v, v, gravity, view(buf, 0, (0, 6)), workspace_in(buf, nb), tau, nonzero(v), False)
    keep_alive(buf)
    return DONE


@kernel
def gravity_single(packed, q, tau):
    tree, gravity, nq = unpack(packed)
    nb = tree.parents.shape[0]
    if not (config_ok(tree, nq, q) and tau.shape[0] == tree.S.shape[0]):
        return GENERAL
    buf = scratch(30 * nb)
    gravity_into(tree, q, gravity, workspace_in(buf, nb), tau)
    keep_alive(buf)
    return DONE


def rnea_entry(self, args, nargs):
    """inverse_dynamics' one call from Python (dynamics._numba.PythonFunction): (packed, q, v, a, tau) -> status."""
    status = GENERAL
    if (nargs == 5 and py_packed(self, args[0]) and py_state(self, args[1]) and py_state(self, args[2])
            and py_state(self, args[3]) and py_result(self, args[4], 1)):
        status = rnea_single(py_array(args[0], PACKED), py_array(args[1], VECTOR), py_array(args[2], VECTOR),
                             py_array(args[3], VECTOR), py_array(args[4], VECTOR))
    return py_status(self, status)


def bias_entry(self, args, nargs):
    """bias_forces' one call from Python: (packed, q, v, tau) -> status."""
    status = GENERAL
    if (nargs == 4 and py_packed(self, args[0]) and py_state(self, args[1]) and py_state(self, args[2])
            and py_result(self, args[3], 1)):
        status = bias_single(py_array(args[0], PACKED), py_array(args[1], VECTOR), py_array(args[2], VECTOR),
                             py_array(args[3], VECTOR))
    return py_status(self, status)


def gravity_entry(self, args, nargs):
    """gravity_torques' one call from Python: (packed, q, tau) -> status."""
    status = GENERAL
    if nargs == 3 and py_packed(self, args[0]) and py_state(self, args[1]) and py_result(self, args[2], 1):
        status = gravity_single(py_array(args[0], PACKED), py_array(args[1], VECTOR), py_array(args[2], VECTOR))
    return py_status(self, status)


# -- public entry points ---------------------------------------------------------------------------
_rnea_batch = Kernel(rnea_batch)
_gravity_batch = Kernel(gravity_batch)
_rnea_single = PythonFunction(rnea_entry, (DONE, GENERAL))
_bias_single = PythonFunction(bias_entry, (DONE, GENERAL))
_gravity_single = PythonFunction(gravity_entry, (DONE, GENERAL))


def _run(model, q, v, a, gravity, f_ext):
    checks.check_model(model)
    Q, (V, A), B, batched = checks.state_batch(model, q, (("v", v, model.nv), ("a", a, model.nv)))
    F = checks.external_forces(model, f_ext, B)
    g = checks.gravity_vector(model, gravity)
    with_v, with_a = bool(V.any()), bool(A.any())  # zero terms are skipped, not computed
    out = np.empty((B, model.nv))
    run_chunks(_rnea_batch, model.tree, (Q, V, A, F), (g, with_v, with_a), out)
    return out if batched else out[0]


def skipped_terms(v=None, a=None, gravity=(0.0, 0.0, -9.81)):
    """Names of the terms a call with these inputs does not compute (for scene reports)."""
    out = []
    if v is None or not np.any(v):
        out.append("velocity products")
    if a is None or not np.any(a):
        out.append("joint accelerations")
    if gravity is not None and not np.any(gravity):
        out.append("gravity")
    return out


def inverse_dynamics(model, q, v, a, *, gravity=None, f_ext=None):
    """Joint torques tau = M(q) a + C(q, v) v + g(q) - J^T f_ext (RNEA).

    q: (nq,) or (B, nq); v, a: (nv,) or (B, nv); gravity: (3,) in the world frame (default model.gravity);
    f_ext: (nbodies, 6) or (B, nbodies, 6), one [force, torque] per body in its body frame, torque about the
    body frame origin.  Returns tau of shape (nv,) or (B, nv).
    """
    try:  # one state: one compiled call, which checks q, v and a itself (anything else takes the general path)
        if gravity is None and f_ext is None:
            tau = np.empty(model.nv)
            if _rnea_single.call(model.packed, q, v, a, tau) == DONE:
                return tau
    except AttributeError:  # not a model: the general path says so
        pass
    return _run(model, q, v, a, gravity, f_ext)


def gravity_torques(model, q, *, gravity=None):
    """g(q): the torques that hold the robot still against gravity, (nv,) or (B, nv)."""
    try:  # the fast path, as in inverse_dynamics
        if gravity is None:
            tau = np.empty(model.nv)
            if _gravity_single.call(model.packed, q, tau) == DONE:
                return tau
    except AttributeError:
        pass
    checks.check_model(model)
    Q, batched = checks.configurations(model, q)
    out = np.empty((Q.shape[0], model.nv))
    run_chunks(_gravity_batch, model.tree, (Q,), (checks.gravity_vector(model, gravity),), out)
    return out if batched else out[0]


def bias_forces(model, q, v, *, gravity=None):
    """C(q, v) v + g(q): inverse dynamics at zero acceleration, (nv,) or (B, nv)."""
    try:  # the fast path, as in inverse_dynamics
        if gravity is None:
            tau = np.empty(model.nv)
            if _bias_single.call(model.packed, q, v, tau) == DONE:
                return tau
    except AttributeError:
        pass
    checks.check_model(model)
    return _run(model, q, v, np.zeros(model.nv), gravity, None)
