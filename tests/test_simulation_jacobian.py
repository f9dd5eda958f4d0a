"""The robot's right-hand-side Jacobian df/dz (:mod:`dynamics.simulation.jacobian`, Radau's Newton matrix and
the variational equations' df/dx) against central differences of the right-hand side itself, on a floating
base (the free joint's chart: its rate depends on delta) with PD, damping, friction and active limit springs."""

import importlib
import os

import numpy as np
import pytest
from numba import njit

import dynamics
from dynamics.control.validation import make_source
from dynamics.simulation.jacobian import robot_jacobian
from dynamics.simulation.problem import rhs, robot_problem
from dynamics.simulation.solvers import new_stats
from dynamics.torques import PD
from robots import OUR_ROBOTS, erd

simulate_module = importlib.import_module("dynamics.simulation.simulate")


@njit
def _jacobian(p, t, z, J, st):
    robot_jacobian(p, t, z, z, z, 0, J, st[0])


@njit
def _rhs(p, t, z, f):
    rhs(p, t, z, f)


def _problem(model, q0, v0, torque):
    s = simulate_module._settings(model, q0, v0, 1.0, "radau", 1e-6, 1e-8, None, None, None, 10, "none", ("q",),
                                  [], None, False)
    ps = simulate_module._passive(model, s, "spring", 1e4, 100.0, 1e-2)
    ps = ps._replace(damping=np.full(model.nv, 0.3), friction=np.full(model.nv, 0.2))
    return robot_problem(model, ps, make_source(model, torque), s.q0, np.zeros(1), ())


@pytest.mark.parametrize("floating", [False, True])
def test_jacobian_against_central_differences(floating):
    """planar 3R fixed; Panda on a free joint (the chart's rate depends on delta there)."""
    if floating:
        model = dynamics.load_urdf(erd("panda_description/urdf/panda.urdf"), mimic="independent", floating_base=True)
    else:
        model = dynamics.load_urdf(os.path.join(OUR_ROBOTS, "planar_3r.urdf"))
    rng = np.random.default_rng(1)
    n1 = model.nv - (6 if floating else 0)  # the 1-dof joints, after the free joint's 7 coordinates
    q0 = model.neutral()
    q0[-n1:] += 0.3 * rng.uniform(-1, 1, n1)
    q0[-1] = model.upper[-1] + 0.02  # the last joint beyond its limit: the spring pushes
    v0 = rng.uniform(-1, 1, model.nv)
    p = _problem(model, q0, v0, PD(model.neutral(), 5.0, 0.5))
    nv, n = model.nv, 2 * model.nv + 2
    z = np.zeros(n)
    z[:nv] = 0.05 * rng.standard_normal(nv)  # away from the chart's centre
    z[nv:2 * nv] = v0
    J = np.zeros((n, n))
    _jacobian(p, 0.3, z, J, new_stats())
    F = np.zeros((n, n))
    fp, fm = np.empty(n), np.empty(n)
    for k in range(2 * nv):
        h = 1e-6
        zp, zm = z.copy(), z.copy()
        zp[k] += h
        zm[k] -= h
        _rhs(p, 0.3, zp, fp)
        _rhs(p, 0.3, zm, fm)
        F[:, k] = (fp - fm) / (2 * h)
    scale = np.abs(F).max(axis=1, keepdims=True) + 1.0
    np.testing.assert_allclose(J / scale, F / scale, atol=1e-6)
    assert np.abs(J[:, 2 * nv:]).max() == 0.0  # f does not depend on the quadratures
