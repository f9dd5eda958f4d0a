"""A :class:`~dynamics.contact.config.Contact` made concrete for one model: the scene (:func:`.scene.build_scene`)
and each pair's material row (the combination rules of :mod:`.config`), shared by every run of a simulate call
(:class:`Resolved`); and a run's contact in the C++ core (:class:`CoreContact`, ``core/contact/contact_model.hpp``:
the narrow phase's buffer, the forces, the clearance that lets a robot touching nothing skip the contact code, and
what a run writes for the report and the outputs: the largest penetration, the time in contact, the contacts
kept per sample).
"""

import threading
import weakref
from typing import NamedTuple

import numpy as np

from ..errors import InputError
from .config import Contact, combine
from .forces import NMAT
from .scene import build_scene

#: columns of a kept contact (ContactModel.out): pair index, point (3), normal (3), normal force, friction (3),
#: depth, slip velocity (3)
OUT_COLUMNS = ("pair", "point", "point", "point", "normal", "normal", "normal", "normal_force", "friction",
               "friction", "friction", "depth", "slip", "slip", "slip")
NOUT = len(OUT_COLUMNS)


class Resolved(NamedTuple):
    """A Contact resolved for a model: the scene (with names) and the pairs' materials, shared by every run of
    a simulate call; :func:`core_contact` makes each run's contact."""

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
