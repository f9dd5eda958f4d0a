"""The C++ core's right-hand-side Jacobian df/dz (core/simulation/robot_jacobian.cpp: Radau's Newton matrix and the
variational equations' df/dx) against central differences of the core's right-hand side itself, through
``_core.problem_jacobian`` (f and J at one state of the robot problem, z in the chart around q0).

Cases: a planar 3R beyond a joint limit under PD with damping and friction (the passive torques' derivatives, the
PD's analytical one); Panda on a free joint under PD (the chart's rate depends on delta, the analytical source
derivative is carried to the chart); a spherical joint on a planar joint under a Python callable (the source
differenced alone in the chart); the planar 2R under computed torque and Panda under the operational-space
controller (a pose target with a posture; both sources' derivatives analytical
in the core, core/control/computed_torque_derivatives.cpp and operational_space_derivatives.cpp)."""

import importlib
import os

import numpy as np
import pytest

import dynamics
from dynamics import _core
from dynamics.control.validation import make_source
from dynamics.simulation.native import core_passive, core_source
from dynamics.torques import PD, ComputedTorque, Target
from robots import OUR_ROBOTS, erd
from test_sensitivities_floating import SPHERICAL_ON_PLANAR

simulate_module = importlib.import_module("dynamics.simulation.simulate")


def _core_problem(model, q0, v0, torque):
    """The core's passive torques (damping 0.3, friction 0.2, limit springs) and source, and q0 as simulate keeps it."""
    s = simulate_module._settings(model, q0, v0, 1.0, "radau", 1e-6, 1e-8, None, None, None, 10, "none", ("q",),
                                  [], None, False)
    ps = simulate_module._passive(model, s, "spring", 1e4, 100.0, 1e-2)
    ps = ps._replace(damping=np.full(model.nv, 0.3), friction=np.full(model.nv, 0.2))
    return core_passive(model, ps), core_source(model, make_source(model, torque)), s.q0


def _f_and_J(model, passive, source, q0, z, t):
    n = z.shape[0]
    f, J = np.zeros(n), np.full((n, n), np.nan)
    analytical = _core.problem_jacobian(model.core, passive, source, q0, z, t, f, J)
    return f, J, analytical


def _planar_3r():
    model = dynamics.load_urdf(os.path.join(OUR_ROBOTS, "planar_3r.urdf"))
    rng = np.random.default_rng(1)
    q0 = model.neutral() + 0.3 * rng.uniform(-1, 1, model.nv)
    q0[-1] = model.upper[-1] + 0.02  # beyond its limit: the spring pushes
    return model, q0, rng.uniform(-1, 1, model.nv), PD(model.neutral(), 5.0, 0.5)


def _floating_panda():
    model = dynamics.load_urdf(erd("panda_description/urdf/panda.urdf"), mimic="independent", floating_base=True)
    rng = np.random.default_rng(2)
    q0 = model.neutral()
    q0[7:] += 0.3 * rng.uniform(-1, 1, model.nq - 7)
    q0 = dynamics.integrate(model, q0, np.r_[0.1, -0.2, 0.3, 0.4, -0.3, 0.2, np.zeros(model.nv - 6)])
    return model, q0, rng.uniform(-1, 1, model.nv), PD(model.neutral(), 20.0, 2.0)


def _spherical_on_planar():
    model = dynamics.load_urdf(SPHERICAL_ON_PLANAR)
    q0 = dynamics.integrate(model, model.neutral(), np.array([0.1, -0.2, 0.5, 0.6, -0.4, 0.3]))
    v0 = np.array([0.2, 0.1, -0.5, 1.0, 0.5, -2.0])
    return model, q0, v0, lambda t, q, v: -np.r_[2.0 * q[:2], 1.0 * q[4:8]] - 0.3 * v * np.abs(v)


def _two_r_computed_torque():
    model = dynamics.load_urdf(os.path.join(OUR_ROBOTS, "planar_2r.urdf"))
    t = np.linspace(0.0, 0.5, 6)
    ref_q = np.stack([0.3 * np.sin(t), 0.2 * np.cos(t)], 1)
    ref_v = np.stack([0.3 * np.cos(t), -0.2 * np.sin(t)], 1)
    ref_a = np.stack([-0.3 * np.sin(t), -0.2 * np.cos(t)], 1)
    return model, np.array([0.1, 0.2]), np.array([0.3, -0.4]), ComputedTorque(t, ref_q, ref_v, ref_a, 100.0, 20.0)


def _panda_operational_space():
    model = dynamics.load_urdf(erd("panda_description/urdf/panda.urdf"), mimic="independent")
    q0 = np.array([0.5, 0.3, -0.4, -1.5, 0.3, 1.2, 0.0, 0.01, 0.03])
    hand = dynamics.frame_placement(model, q0 + 0.2, "panda_hand")
    return model, q0, np.linspace(-0.5, 0.5, model.nv), Target("panda_hand", hand[:3, 3], hand[:3, :3], kp=100.0,
                                                               kd=20.0, posture=q0 + 0.1, posture_kp=10.0)


@pytest.mark.parametrize("case", [_planar_3r, _floating_panda, _spherical_on_planar, _two_r_computed_torque,
                                  _panda_operational_space],
                         ids=["planar_3r_pd_limits", "floating_panda_pd", "spherical_on_planar_callable",
                              "two_r_computed_torque", "panda_operational_space"])
def test_core_jacobian_against_central_differences(case):
    """Row-scaled |J - F| <= 1e-7 (measured: 8e-11 to 1.1e-9; the differences of f are good to ~1e-9)."""
    model, q0, v0, torque = case()
    passive, source, q0 = _core_problem(model, q0, v0, torque)
    nv, n = model.nv, 2 * model.nv + 2
    z = np.zeros(n)
    z[:nv] = 0.05 * np.random.default_rng(7).standard_normal(nv)  # away from the chart's centre
    z[nv:2 * nv] = v0
    t = 0.3
    f, J, analytical = _f_and_J(model, passive, source, q0, z, t)
    assert analytical
    assert np.all(np.isfinite(f)) and np.all(np.isfinite(J))
    F = np.zeros((n, n))
    for k in range(2 * nv):
        h = 1e-6 * max(1.0, abs(z[k]))
        zp, zm = z.copy(), z.copy()
        zp[k] += h
        zm[k] -= h
        fp = _f_and_J(model, passive, source, q0, zp, t)[0]
        fm = _f_and_J(model, passive, source, q0, zm, t)[0]
        F[:, k] = (fp - fm) / (2 * h)
    scale = np.abs(F).max(axis=1, keepdims=True) + 1.0
    err = np.abs(J - F) / scale
    assert err.max() <= 1e-7, (err.max(), np.unravel_index(err.argmax(), err.shape))
    assert np.abs(J[:, 2 * nv:]).max() == 0.0  # f does not depend on the quadratures
    assert np.abs(J[nv:2 * nv, :2 * nv]).max() > 1.0  # the dynamics' block is there (not a zero matrix)



BALL = """<robot name="ball"><link name="ball"><inertial><mass value="2"/>
<inertia ixx="0.02" iyy="0.02" izz="0.02" ixy="0" ixz="0" iyz="0"/></inertial></link></robot>"""


@pytest.mark.parametrize("exact", [True, False], ids=["sensitivities", "radau"])
def test_core_jacobian_with_contact_against_central_differences(exact):
    """A ball pressed into the ground and sliding (friction past its Stribeck drop, damping active): with
    ``exact`` (a run with sensitivities) the whole J against central differences of f, the contact's d tau_c/dq
    differenced by the core; without, its v columns (d tau_c/dv is analytical and exact) and the contact power's
    row, while the q columns carry the contact's stiffness only (Radau's Newton matrix)."""
    from dynamics.contact.resolve import core_contact, resolve
    model = dynamics.load_urdf(BALL, floating_base=True)
    contact = dynamics.Contact(geometries=[dynamics.Sphere("ball", 0.1)],
                               friction=dynamics.Material(stiffness=2e5, dissipation=0.5, mu_static=0.8,
                                                          mu_dynamic=0.5, stiction_velocity=1e-3))
    passive, source, q0 = _core_problem(model, np.array([0, 0, 0.097, 0, 0, 0, 1.0]), np.zeros(6), None)
    cm = core_contact(resolve(contact, model), model, exact=exact).core
    nv, n = model.nv, 2 * model.nv + 3
    z = np.zeros(n)
    z[:nv] = [0.001, -0.002, 0.0005, 0.02, -0.01, 0.03]
    z[nv:2 * nv] = [0.3, -0.2, -0.05, 0.5, 1.0, -0.3]  # sliding, approaching
    f, J = np.zeros(n), np.full((n, n), np.nan)
    assert _core.problem_jacobian(model.core, passive, source, q0, z, 0.0, f, J, cm)
    assert f[2 * nv + 2] != 0.0  # the contact's power: it touches
    F = np.zeros((n, n))
    for k in range(2 * nv):
        h = 1e-7 * max(1.0, abs(z[k]))
        fs = []
        for s in (1, -1):
            zs = z.copy()
            zs[k] += s * h
            fz = np.zeros(n)
            _core.problem_jacobian(model.core, passive, source, q0, zs, 0.0, fz, np.empty((n, n)), cm)
            fs.append(fz)
        F[:, k] = (fs[0] - fs[1]) / (2 * h)
    scale = np.abs(F).max(axis=1, keepdims=True) + 1.0
    err = np.abs(J - F) / scale
    cols = slice(0, 2 * nv) if exact else slice(nv, 2 * nv)
    assert err[:, cols].max() <= 1e-6, (err[:, cols].max(), np.unravel_index(err[:, cols].argmax(), err[:, cols].shape))
    if not exact:  # the stiffness part: the large entries of da/dq, not all of it
        assert np.abs(J[nv + 2, 2] - F[nv + 2, 2]) <= 0.05 * np.abs(F[nv + 2, 2])
