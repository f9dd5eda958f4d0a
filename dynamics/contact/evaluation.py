"""Contact forces of one state, from Python: :func:`contact_forces` gives the body wrenches ``f_ext`` that every
dynamics function takes (:func:`dynamics.inverse_dynamics`, :func:`dynamics.forward_dynamics`, ...), and on
request each active contact (:class:`ContactDetails`).  The law is :mod:`.forces`'; the same evaluation in
the core as the simulation's right-hand side (``core/contact/contact_model.cpp``)."""

from typing import NamedTuple

import numpy as np

from ..checks import check_model, configurations, vector
from ..errors import InputError
from .forces import D_ELASTIC, D_FN, D_FT, D_SLIP


class ContactDetails(NamedTuple):
    """The active contacts of one state (n of them; world frame; the force on geometry a is
    ``normal_force * normal + friction``, its opposite acts on b).  ``pairs[k]``: the names of contact k's
    geometries (a, b); ``generalized_force`` (nv,): J_c^T f_c; ``power``: the contact forces' power (W);
    ``elastic_energy``: sum 1/2 k x^2 (J)."""

    pairs: list
    point: np.ndarray  # (n, 3)
    normal: np.ndarray  # (n, 3) unit, from b towards a
    normal_force: np.ndarray  # (n,)
    friction: np.ndarray  # (n, 3)
    depth: np.ndarray  # (n,)
    slip: np.ndarray  # (n, 3)
    generalized_force: np.ndarray  # (nv,)
    power: float
    elastic_energy: float


def contact_forces(model, contact, q, v, *, details=False):
    """The contact wrenches of the state (q, v): f_ext (nbodies, 6), body frame, [force, torque about the body
    origin] (:func:`dynamics.inverse_dynamics`'s convention), so that ``forward_dynamics(model, q, v, tau,
    f_ext=f_ext)`` is the acceleration a simulation with ``contact`` has.  contact: a :class:`dynamics.Contact`.
    With ``details=True`` returns (f_ext, :class:`ContactDetails`)."""
    from .resolve import Resolved, core_contact, resolve
    check_model(model)
    r = contact if isinstance(contact, Resolved) else resolve(contact, model)
    Q, batched = configurations(model, q)
    if batched:
        raise InputError(f"q: expected one state of shape ({model.nq},), got {np.shape(q)}")
    v = vector("v", v, model.nv)
    f_ext = np.zeros((model.tree.parents.shape[0], 6))
    tau = np.zeros(model.nv)
    power, pair, point, normal, depth, d = core_contact(r, model).core.evaluate(Q[0], v, f_ext, tau)
    if not details:
        return f_ext
    scene = r.scene
    pairs = [(scene.names[scene.pair_a[j]], scene.names[scene.pair_b[j]]) for j in pair]
    return f_ext, ContactDetails(pairs, point, normal, d[:, D_FN].copy(), d[:, D_FT:D_FT + 3].copy(), depth,
                                 d[:, D_SLIP:D_SLIP + 3].copy(), tau, float(power), float(np.sum(d[:, D_ELASTIC])))


def elastic_energy_at(model, resolved, q, v):
    """sum 1/2 k x^2 over the contacts of the state (q, v) (J)."""
    from .resolve import core_contact
    q = np.ascontiguousarray(q, float)
    v = np.ascontiguousarray(v, float)
    d = core_contact(resolved, model).core.evaluate(q, v, np.zeros((model.tree.parents.shape[0], 6)),
                                                    np.zeros(model.nv))[-1]
    return float(np.sum(d[:, D_ELASTIC]))
