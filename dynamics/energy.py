"""Kinetic and potential energy.

    T(q, v) = 1/2 sum_i v_i . I_i v_i          (body velocities v_i from the forward pass)
    U(q)    = - sum_i m_i g . c_i^world        (c_i^world = p_i + R_i c_i, world pose of body i)

With a fixed base the world is the root link's frame; U is zero when every centre of mass is at height 0
along g.

The public functions are the core's (``core/energy.cpp``); a simulation evaluates the energy of every sample
as it writes it (:func:`sample_energies`, from the run's ``emit``) with the ABA's first pass and workspace.
"""

import numpy as np

from . import _core, checks
from .parallel import run


def kinetic_energy(model, q, v):
    """T = 1/2 v^T M(q) v (J): a float, or (B,) for a batch."""
    checks.check_model(model)
    Q, (V,), B, batched = checks.state_batch(model, q, (("v", v, model.nv),))
    out = run(_core.energy_batch, model, Q, V, np.zeros(3), True, False, out=np.empty((B, 2)))
    return out[:, 0] if batched else float(out[0, 0])


def potential_energy(model, q, *, gravity=None):
    """U = -sum m_i g . c_i (J), zero reference at the world origin: a float, or (B,) for a batch."""
    checks.check_model(model)
    Q, bq = checks.configurations(model, q)
    g = checks.gravity_vector(model, gravity)
    out = run(_core.energy_batch, model, Q, np.zeros((1, model.nv)), g, False, True, out=np.empty((Q.shape[0], 2)))
    return out[:, 1] if bq else float(out[0, 1])
