"""The Jacobians of the configuration update, joint by joint (Pinocchio's ``dIntegrate`` and ``dDifference``).

``integrate(model, q, v)`` is q (+) v: per joint q + v for 1-dof joints, and M Exp(xi) for the free joint
(M its pose, xi = (v_lin, omega) its body twist, the SE(3) exponential), the spherical (SO(3)) and the planar
joint (SE(2)).  :func:`dynamics.difference` is its inverse, q1 (-) q0: q1 - q0, and Log(M0^-1 M1).  Derivatives with respect to q are in the tangent
space (along q (+) dq, as everywhere in the library), so every Jacobian is (nv, nv) and block diagonal, one
block per joint:

    d(q (+) v)/dq = Ad(Exp(xi))^-1,           d(q (+) v)/dv = Jr(xi)
    d(q1 (-) q0)/dq1 = Jr(d)^-1,              d(q1 (-) q0)/dq0 = -Jr(d)^-1 Ad(Exp(d))^-1,   d = q1 (-) q0

with Ad(R, p) = [[R, [p] R], [0, R]] in the (linear, angular) order of a free joint's v, and Jr the right
Jacobian of SE(3) (Barfoot, "State estimation for robotics", 2017, eqs. 7.83-7.86, with Jr(xi) = Jl(-xi)):

    Jl(xi) = [[Jl(phi), Q(rho, phi)], [0, Jl(phi)]],   Jl(phi) = 1 + (1 - cos t)/t^2 [phi] + (t - sin t)/t^3 [phi]^2

For 1-dof joints the blocks are 1 (and -1 for dq0).  The spherical and planar joints' groups are subgroups of
SE(3) (rotations; motions in the plane of the joint's in-plane directions u, w, about its axis): their blocks
are the rows and columns of the SE(3) blocks at their twist (angular; (v_u, v_w, w_axis)), since the exponential
of a subgroup is the restriction of SE(3)'s.

The Jacobians are the core's (``core/configuration_jacobians.cpp``); this module checks the arguments and calls it.
"""

import numpy as np

from . import _core, checks
from .configuration import difference


def integrate_jacobians(model, q, v):
    """(d/dq, d/dv) of integrate(model, q, v), each (nv, nv), q in the tangent space (Pinocchio's dIntegrate
    with ARG0 and ARG1; module docstring).  One state."""
    checks.check_model(model)
    checks.vector("q", q, model.nq)
    v = checks.vector("v", v, model.nv)
    Jq, Jv = np.empty((model.nv, model.nv)), np.empty((model.nv, model.nv))
    _core.integrate_jacobians(model.core, v, Jq, Jv)
    return Jq, Jv


def difference_jacobians(model, q0, q1):
    """(d/dq0, d/dq1) of dynamics.difference(model, q0, q1), each (nv, nv), both in the tangent space
    (Pinocchio's dDifference with ARG0 and ARG1; module docstring).  One state."""
    d = difference(model, q0, q1)
    J0, J1 = np.empty((model.nv, model.nv)), np.empty((model.nv, model.nv))
    if not _core.difference_jacobians(model.core, d, J0, J1):  # Jr(d) is singular only at an angle of 2 pi
        raise np.linalg.LinAlgError("difference_jacobians: a joint's Jr(d) is singular")
    return J0, J1
