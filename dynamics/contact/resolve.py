"""A :class:`~dynamics.contact.config.Contact` made concrete for one model: the scene (:func:`.scene.build_scene`),
each pair's material row (the combination rules of :mod:`.config`), and the buffers of the compiled evaluation;
and that evaluation, which the simulation's right-hand side calls (:func:`contact_torques`).

:class:`ContactModel` (K = scene.max_contacts, the narrow phase's capacity; nb bodies; T kept samples), which a
simulation's problem holds packed into two buffers (:class:`PackedContact`, :mod:`dynamics._numba.packing`):

===========  ================  ==================================================================================
field        shape             meaning
===========  ================  ==================================================================================
scene        SceneArrays       the geometry and candidate pairs (:mod:`.scene`)
pair_body    (npairs, 2) int   the bodies of each pair's geometries a and b (-1: the world)
mat          (npairs, 5)       each pair's k (N/m), d (s/m), mu_s, mu_d, v_s (m/s) (:data:`.forces.K_STIFF` ...)
buf          ContactBuffer     the narrow phase's contacts of the last evaluation (pair, point, normal, depth)
ws           ContactWork       forward pass, world poses, body wrenches (:mod:`.forces`)
detail       (K, 8)            per contact of the last evaluation: f_n, f_t (3), slip (3), elastic energy
tau          (nv,)             scratch: a generalised force nobody reads (tracking, outputs)
track        (3,)              largest penetration over the accepted steps (m), time in contact (s), last step's t
out          (T, K, 15) or 0   contacts kept per sample (:data:`OUT_COLUMNS`); out_n (T,) int64 how many
touched      (3,) int64        [0] 1 when an evaluation found a contact since :func:`_touched` last looked (the
                               Jacobian's); [1] 1 while the last accepted state touches; [2] 1 once
                               :func:`_touchdown` reported the present episode of contact (``auto``'s)
exact        (1,) int64        1: the run's Jacobian differences d tau_c/dq (a run with sensitivities needs it
                               exact); 0: its stiffness part (:mod:`.force_derivatives`) serves Radau's Newton
clear        Clearance         how far the robot is from touching anything, and how far it moved since
                               (:mod:`.clearance`): the right-hand side skips the contact code while apart
no_f_ext     (0, 6)            an empty f_ext: the simulation keeps only the generalised force
===========  ================  ==================================================================================
"""

import threading
import weakref
from typing import NamedTuple

import numpy as np

from .._numba import borrow, inline_kernel, kernel
from .._numba.packing import Packing, unpack
from ..errors import InputError
from .clearance import Clearance, advance, apart, clearance, set_reference
from .config import Contact, combine
from .force_derivatives import contact_force_derivatives
from .forces import (D_FN, D_FT, D_SLIP, NDETAIL, NMAT, ContactWork, apply_contacts, contact_work,
                     generalized_forces, world_kinematics, world_poses)
from .narrow_phase import ContactBuffer, _collide, contact_buffer
from .scene import SceneArrays, build_scene

#: columns of a kept contact (ContactModel.out): pair index, point (3), normal (3), normal force, friction (3),
#: depth, slip velocity (3)
OUT_COLUMNS = ("pair", "point", "point", "point", "normal", "normal", "normal", "normal_force", "friction",
               "friction", "friction", "depth", "slip", "slip", "slip")
NOUT = len(OUT_COLUMNS)


class ContactModel(NamedTuple):
    """The compiled evaluation's record (fields in the module docstring)."""

    scene: tuple
    pair_body: np.ndarray
    mat: np.ndarray
    buf: tuple
    ws: tuple
    detail: np.ndarray
    tau: np.ndarray
    track: np.ndarray
    out: np.ndarray
    out_n: np.ndarray
    touched: np.ndarray
    exact: np.ndarray
    clear: tuple
    no_f_ext: np.ndarray


class Resolved(NamedTuple):
    """A Contact resolved for a model: the scene (with names) and the pairs' materials, shared by every run of
    a simulate call; :func:`contact_model` makes each run's buffers."""

    scene: object  # scene.Scene
    pair_body: np.ndarray
    mat: np.ndarray
    contact: Contact


def model_mass(model):
    return float(np.sum(model.tree.mass))


#: the last few resolutions, by the identity of the contact and the model (both immutable) and the gravity: a
#: loop of short simulate calls with one Contact resolves it once (the scene's checks cost a millisecond)
_RECENT = {}
_RECENT_SIZE = 8
_RECENT_LOCK = threading.Lock()  # (simulate_many's threads resolve at once)


def resolve(contact, model, gravity=None):
    """A :class:`Resolved` for ``contact`` (a :class:`Contact`) on ``model``; materials combined per pair."""
    if not isinstance(contact, Contact):
        raise InputError(f"contact: expected dynamics.Contact(...) or None, got {type(contact).__name__}")
    key = (id(contact), id(model), None if gravity is None else tuple(np.asarray(gravity, float).ravel()),
           tuple(contact.materials.items()))
    with _RECENT_LOCK:
        hit = _RECENT.get(key)
    if hit is not None and hit[0]() is contact and hit[1]() is model:
        return hit[2]
    r = _resolve(contact, model, gravity)
    with _RECENT_LOCK:
        while len(_RECENT) >= _RECENT_SIZE:
            del _RECENT[next(iter(_RECENT))]
        _RECENT[key] = (weakref.ref(contact), weakref.ref(model), r)
    return r


def _resolve(contact, model, gravity):
    scene = build_scene(model, contact.geometries, contact.world, self_collision=contact.self_collision,
                        exclude=contact.exclude, pairs=contact.pairs)
    names = list(scene.names)
    for name in contact.materials:
        if name not in names:
            import difflib
            near = difflib.get_close_matches(name, names, n=5, cutoff=0.4)
            raise InputError(f"materials: no geometry named {name!r} in the scene; "
                             + (f"closest: {near}" if near else f"there are {len(names)}: {names[:12]}"))
    g = float(np.linalg.norm(model.gravity if gravity is None else gravity)) or 9.81
    mass = max(model_mass(model), 1e-300)
    per_geom = [contact.materials.get(n, contact.friction) for n in names]
    kd = [m.defaults(mass, g) for m in per_geom]
    npairs = scene.pair_a.shape[0]
    mat = np.zeros((npairs, NMAT))
    pair_body = np.zeros((npairs, 2), np.int64)
    for j, (a, b) in enumerate(zip(scene.pair_a, scene.pair_b)):
        pair_body[j] = scene.body[a], scene.body[b]
        mat[j] = combine(kd[a], kd[b], per_geom[a], per_geom[b])
    pair_body.flags.writeable = mat.flags.writeable = False  # shared by every run that resolves this contact
    return Resolved(scene, pair_body, mat, contact)


def contact_record(r, model, T=0, exact=False):
    """A :class:`ContactModel` of the resolved contact ``r`` with its own buffers (T samples kept when the
    contact asked for "contacts"); ``exact``: the run's Jacobian needs the exact d tau_c/dq (sensitivities).
    What a single evaluation from Python takes (:func:`evaluate_kernel`); a simulation takes it packed
    (:func:`contact_model`)."""
    nb, nv = model.tree.parents.shape[0], model.nv
    K = int(r.scene.max_contacts)
    T = T if "contacts" in r.contact.outputs else 0
    return ContactModel(r.scene.arrays, r.pair_body, r.mat, contact_buffer(r.scene), contact_work(nb),
                        np.zeros((K, NDETAIL)), np.zeros(nv), np.array([0.0, 0.0, 0.0]), np.zeros((T, K, NOUT)),
                        np.zeros(T, np.int64), np.zeros(3, np.int64), np.array([int(exact)], np.int64),
                        clearance(model), np.zeros((0, 6)))


class PackedContact(NamedTuple):
    """A :class:`ContactModel` packed into two buffers (:mod:`dynamics._numba.packing`): what a simulation's
    problem holds, so that its compiled functions pass two arrays where the record has 37."""

    f: np.ndarray
    i: np.ndarray


def _example():
    """A ContactModel of empty arrays: the dtypes and dimensions of every field (the packing's layout)."""
    def z(*shape, dtype=float):
        return np.zeros(shape, dtype)
    i = np.int64
    scene = SceneArrays(z(0, dtype=i), z(0, dtype=i), z(0, 3), z(0, 3, 3), z(0, 3), z(0), z(0, dtype=i),
                        z(0, dtype=i))
    return ContactModel(scene, z(0, 2, dtype=i), z(0, NMAT), ContactBuffer(z(0, dtype=i), z(0, 3), z(0, 3), z(0),
                                                                          z(2, 8, 3)),
                        contact_work(0), z(0, NDETAIL), z(0), z(3), z(0, 0, NOUT), z(0, dtype=i), z(3, dtype=i),
                        z(1, dtype=i), Clearance(z(3), z(0), z(0), z(0), z(0, dtype=i)), z(0, 6))


LAYOUT = Packing(PackedContact, _example())
#: the fields the checks of a robot touching nothing read (the whole record is unpacked beyond them)
_clearance_of = LAYOUT.unpacker("clear")
_stepped_of = LAYOUT.unpacker("clear", "track", "touched")
_touched_of = LAYOUT.unpacker("touched")
_kept_of = LAYOUT.unpacker("out")


def contact_model(r, model, T=0, exact=False):
    """:func:`contact_record` packed (a :class:`PackedContact`): a simulation run's contact."""
    return LAYOUT.pack(contact_record(r, model, T, exact))


class CoreContact(NamedTuple):
    """A run's contact in the C++ core (``core/contact/contact_model.hpp``): the core's object and the arrays it
    writes, which the report and the outputs read (the :class:`ContactModel` fields of those names)."""

    core: object  # dynamics._core.ContactModel
    track: np.ndarray  # (3,) largest penetration, time in contact, last step's t
    out: np.ndarray  # (T, K, NOUT) contacts kept per sample
    out_n: np.ndarray  # (T,) int64


def core_contact(r, model, T=0, exact=False):
    """A :class:`CoreContact` of the resolved contact ``r`` for one run (T samples kept when the contact asked for
    "contacts"; ``exact``: the run's Jacobian differences d tau_c/dq, as sensitivities need), or for a single
    evaluation (T = 0)."""
    from .. import _core
    K = int(r.scene.max_contacts)
    T = T if "contacts" in r.contact.outputs else 0
    track, out, out_n = np.zeros(3), np.zeros((T, K, NOUT)), np.zeros(T, np.int64)
    S = r.scene
    core = _core.ContactModel(model.core, S.body, S.kind, S.size, S.R, S.p, S.radius, S.pair_a, S.pair_b,
                              r.pair_body, r.mat, K, track, out, out_n, bool(exact))
    return CoreContact(core, track, out, out_n)


def contact_views(c):
    """The :class:`ContactModel` of a :class:`PackedContact` as numpy views (a run's results, in Python); a
    :class:`CoreContact` is its own."""
    return c if isinstance(c, CoreContact) else LAYOUT.views(c)


@inline_kernel
def _found(c, tree, q, v):
    """The number of contacts at q (the narrow phase's, into c.buf); the bodies' world poses into c.ws."""
    world_kinematics(tree, q, v, c.ws, False)
    return _collide(c.scene, c.ws.oR, c.ws.op, c.buf)


@kernel
def evaluate(c, tree, q, v, tau, f_ext):
    """tau += the generalised contact force at (q, v); f_ext (nb, 6) = the body wrenches (a (0, 6) f_ext: not
    kept).  Returns (contact power, number of contacts)."""
    n = _found(c, tree, q, v)
    for i in range(f_ext.shape[0]):
        for r in range(6):
            f_ext[i, r] = 0.0
    if n == 0:  # touching nothing: no velocities, no forces
        return 0.0, 0
    return _forces(c, tree, q, v, tau, f_ext, n), n


@kernel
def _forces(c, tree, q, v, tau, f_ext, n):
    """:func:`evaluate` once the narrow phase found n > 0 contacts; returns the contact power."""
    c.touched[0] = 1
    world_kinematics(tree, q, v, c.ws, True)
    b = c.buf
    power = apply_contacts(n, b.pair, b.point, b.normal, b.depth, c.pair_body, c.mat, c.ws, c.detail)
    for i in range(f_ext.shape[0]):
        for r in range(6):
            f_ext[i, r] = c.ws.fb[i, r]
    generalized_forces(tree, c.ws, tau)
    return power


@kernel
def evaluate_kernel(c, tree, q, v, f_ext, tau):
    """:func:`evaluate` from Python, its arguments borrowed as a simulation's are (the model's read-only arrays
    would otherwise type, and compile, the narrow phase and the forces a second time)."""
    return evaluate(borrow(c), borrow(tree), borrow(q), borrow(v), borrow(tau), borrow(f_ext))


# ---------------------------------------------------------------------------------------------------------
# the implementations of the simulation's calls (:mod:`.calls`) for a PackedContact c: each unpacks the record
# (:func:`dynamics._numba.packing.unpack`; inlined, only the fields it reads are made) and, beyond the
# checks that keep a robot touching nothing cheap, hands it to a kernel, where it is an argument.  Stores
# through the unpacked record outside a kernel use constant indices (the packing module's rule: numba's
# dead-code elimination may drop a store with a variable index there).
def _power(c, tree, q, v, tau, delta):
    return _power_kernel(unpack(c), tree, q, v, tau)


def _power_on_chart(c, tree, q, v, tau, delta):
    """:func:`_power` at q = the chart coordinate ``delta`` around the step's base: nothing while the robot is
    clear of everything (:mod:`.clearance`)."""
    cl, = _clearance_of(c)
    if apart(cl, delta):
        return 0.0
    return _power_kernel(unpack(c), tree, q, v, tau)


def _rebased(c):
    cl, = _clearance_of(c)
    cl.state[2] = 0.0  # (no reference: the next accepted state is measured)


@kernel
def _power_kernel(c, tree, q, v, tau):
    """The contact power, tau += the generalised contact force (the constrained right-hand side's call)."""
    n = _found(c, tree, q, v)
    return _forces(c, tree, q, v, tau, c.no_f_ext, n) if n > 0 else 0.0


def _bias(c, tree, d, pA, delta):
    """After the ABA's first pass at (q, v) (its forward pass d: poses and body velocities; its bias forces pA):
    pA_i -= every body's contact wrench, so that the ABA's other passes take the contact forces as external
    forces, and the contact power is returned.  The contact code runs no forward pass of its own (the robot's
    right-hand side, :func:`dynamics.simulation.problem.rhs`), and nothing at all while the chart coordinate
    ``delta`` keeps the robot clear of everything (:mod:`.clearance`)."""
    cl, = _clearance_of(c)
    if apart(cl, delta):
        return 0.0
    return _bias_near(unpack(c), tree, d, pA)


@kernel
def _bias_near(c, tree, d, pA):
    """:func:`_bias` when the robot may touch something: the poses, the narrow phase, the forces."""
    world_poses(tree, d, c.ws.oR, c.ws.op)
    n = _collide(c.scene, c.ws.oR, c.ws.op, c.buf)
    return _bias_forces(c, d, pA, n) if n > 0 else 0.0  # touching nothing: no forces


@kernel
def _bias_forces(c, d, pA, n):
    """:func:`_bias` once the narrow phase found n > 0 contacts (a kernel, as :func:`_forces`: numba's inlining
    of the force law into the inlined call lost its writes)."""
    c.touched[0] = 1
    cw = ContactWork(d, c.ws.oR, c.ws.op, c.ws.fb)
    b = c.buf
    power = apply_contacts(n, b.pair, b.point, b.normal, b.depth, c.pair_body, c.mat, cw, c.detail)
    fb = cw.fb
    for i in range(fb.shape[0]):  # fb: [force, torque]; pA: [moment, force] (dynamics.aba)
        for r in range(3):
            pA[i, r] -= fb[i, 3 + r]
            pA[i, 3 + r] -= fb[i, r]
    return power


def _track(c, tree, t, q, v, delta):
    cl, track, touched = _stepped_of(c)
    if advance(cl, delta):  # still clear of everything since the reference: no contact
        touched[1] = 0
        track[2] = t
        return
    _track_near(unpack(c), tree, t, q, v)


@kernel
def _track_near(c, tree, t, q, v):
    """:func:`_track` when the accepted state must be measured: its contacts, and the clearance from it."""
    tr = c.track
    n = _found(c, tree, q, v)
    set_reference(c.clear, c.scene, tree, c.ws.oR, c.ws.op)
    for k in range(n):
        tr[0] = max(tr[0], c.buf.depth[k])
    if n > 0:
        tr[1] += t - tr[2]
        c.touched[0] = 1
    c.touched[1] = 1 if n > 0 else 0
    tr[2] = t


def _jacobian(c, tree, q, v, dq, dv):
    return jacobian_kernel(unpack(c), tree, q, v, dq, dv)


@kernel
def jacobian_kernel(c, tree, q, v, dq, dv):
    """dv = d tau_c/dv, dq = its stiffness part of d tau_c/dq at (q, v) (:func:`.calls.contact_jacobian`) for a
    ContactModel c; returns whether the run needs the exact d tau_c/dq."""
    n = _found(c, tree, q, v)
    b = c.buf
    contact_force_derivatives(tree, n, b.pair, b.point, b.normal, b.depth, c.pair_body, c.mat, c.ws.oR, c.ws.op, v,
                              dq, dv)
    return c.exact[0] > 0


def _touched(c):
    touched, = _touched_of(c)
    found = touched[0] > 0
    touched[0] = 0
    return found


def _touchdown(c):
    touched, = _touched_of(c)
    if touched[1] == 0:  # the accepted state touches nothing: the next contact is a new episode
        touched[2] = 0
        return False
    if touched[2] == 1:
        return False
    touched[2] = 1
    return True


def _emit(c, tree, j, q, v):
    out, = _kept_of(c)
    if out.shape[0] > 0:  # (inlined into the sample's code: a call passing the whole record costs ~0.4 us)
        _emit_kept(unpack(c), tree, j, q, v)


@kernel
def _emit_kept(c, tree, j, q, v):
    """Sample j's active contacts into c.out[j] (a run that keeps them)."""
    n = evaluate(c, tree, q, v, c.tau, c.no_f_ext)[1]
    c.out_n[j] = n
    b, o = c.buf, c.out[j]
    for k in range(n):
        o[k, 0] = b.pair[k]
        for r in range(3):
            o[k, 1 + r] = b.point[k, r]
            o[k, 4 + r] = b.normal[k, r]
            o[k, 8 + r] = c.detail[k, D_FT + r]
            o[k, 12 + r] = c.detail[k, D_SLIP + r]
        o[k, 7] = c.detail[k, D_FN]
        o[k, 11] = b.depth[k]
