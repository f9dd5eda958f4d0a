"""Forward sensitivities of simulations of models with free, spherical and planar joints, and with contact
(``simulate(..., sensitivities=...)``, :mod:`dynamics.simulation.sensitivities`), against central finite
differences of whole simulations in the tangent space: q0 perturbed as integrate(q0, +-h e_k) (Pinocchio's
convention), the final configurations compared as difference(q(t), q~(t)).

Cases: a free body tumbling in zero gravity (the chart's rotation re-centred at every step, S carried across),
a spherical joint on a planar joint under gravity and PD, and a ball dropped through an impact, sliding and spinning
(contact and friction).  The reported error bound holds within a factor of 10 of the true error.

Compile cost: two solver signatures, rk45 with a PD source and sensitivities without contact, and with contact;
the finite-difference runs reuse them by asking for the cheapest sensitivity (one PD gain).
"""

import numpy as np
import pytest

import dynamics
from dynamics.errors import InputError
from dynamics.torques import PD

TIGHT = dict(integrator="rk45", rtol=1e-12, atol=1e-14, error_estimate="none", outputs=("q", "v"),
             sensitivities=("kd",))


def inertial(m, ixx, iyy, izz):
    return (f'<inertial><mass value="{m}"/><inertia ixx="{ixx}" iyy="{iyy}" izz="{izz}" ixy="0" ixz="0" iyz="0"/>'
            '</inertial>')


BODY = f'<robot name="body"><link name="body">{inertial(1.0, 0.02, 0.05, 0.07)}</link></robot>'
SPHERICAL_ON_PLANAR = (
    '<robot name="sp"><link name="world"/>'
    f'<link name="cart">{inertial(2.0, 0.01, 0.01, 0.02)}</link>'
    f'<link name="bob"><inertial><origin xyz="0.1 0.05 -0.3"/><mass value="1.0"/><inertia ixx="0.01" iyy="0.02" '
    'izz="0.015" ixy="0" ixz="0" iyz="0"/></inertial></link>'
    '<joint name="slide" type="planar"><parent link="world"/><child link="cart"/><axis xyz="0 0 1"/></joint>'
    '<joint name="ball" type="spherical"><parent link="cart"/><child link="bob"/><origin xyz="0 0 0.1"/></joint>'
    '</robot>')


def tangent_fd(model, q0, v0, duration, columns, h, torque_of=None, tight=TIGHT, **kw):
    """Central differences of every sample's state in the x0-columns ``columns`` (k < nv: q0 along the tangent
    e_k; k >= nv: v0[k - nv]) or in a named PD gain (a pair (name, i), ``torque_of(name, i, +-h)`` building the
    perturbed torque).  Returns (T, 2 nv, len(columns)) with tangent q-rows, around a reference run."""
    nv = model.nv
    ref = dynamics.simulate(model, q0, v0, duration, torque=None if torque_of is None else torque_of(None, 0, 0.0),
                            **tight, **kw)
    out = np.empty((len(ref.t), 2 * nv, len(columns)))
    for c, col in enumerate(columns):
        runs = []
        for s in (h, -h):
            q, v, torque = q0, v0, None if torque_of is None else torque_of(None, 0, 0.0)
            if isinstance(col, tuple):
                torque = torque_of(col[0], col[1], s)
            elif col < nv:
                q = dynamics.integrate(model, q0, s * np.eye(nv)[col])
            else:
                v = v0 + s * np.eye(nv)[col - nv]
            tr = dynamics.simulate(model, q, v, duration, torque=torque, **tight, **kw)
            dq = np.array([dynamics.difference(model, a, b) for a, b in zip(ref.q, tr.q)])
            runs.append(np.concatenate([dq, tr.v - ref.v], axis=1))
        out[:, :, c] = (runs[0] - runs[1]) / (2 * h)
    return ref, out


@pytest.fixture(scope="module")
def body():
    model = dynamics.load_urdf(BODY, floating_base=True)
    q0 = dynamics.integrate(model, model.neutral(), np.array([0.1, -0.2, 0.3, 0.4, -0.3, 0.2]))
    v0 = np.array([0.3, -0.1, 0.2, 1.0, 3.0, 0.5])  # near the intermediate axis: an unstable tumble

    def pd(name, i, s):  # a weak damping toward rest, so that "kd" is a parameter
        kd = np.full(6, 0.01)
        if name == "kd":
            kd[i] += s
        return PD(q0, 0.0, kd)
    return model, q0, v0, pd


def test_tumbling_free_body_against_finite_differences(body):
    """S in the tangent space at every sample (dense output between steps: the chart's delta is not zero there)."""
    model, q0, v0, pd = body
    tr = dynamics.simulate(model, q0, v0, 1.0, torque=pd(None, 0, 0.0), integrator="rk45", rtol=1e-10,
                           atol=1e-12, sensitivities=("x0", "kd"), error_estimate="none", gravity=[0, 0, 0],
                           sample_dt=0.05)
    assert tr.report["sensitivities"]["columns"][:6] == [f"q0[{i}]" for i in range(6)]  # tangent components
    np.testing.assert_array_equal(tr.sensitivities[0][:, :12], np.eye(12))
    cols = list(range(12)) + [("kd", 4)]
    ref, F = tangent_fd(model, q0, v0, 1.0, cols, 1e-5, pd, gravity=[0, 0, 0], sample_dt=0.05)
    S = tr.sensitivities[:, :, list(range(12)) + [12 + 4]]
    assert np.abs(F).max() > 3.0  # the tumble amplifies perturbations
    err = np.abs(S - F).max(axis=(1, 2))
    assert err.max() <= 1e-8 * np.abs(F).max(), err.max()


def test_free_body_error_bound_holds(body):
    model, q0, v0, pd = body
    kw = dict(torque=pd(None, 0, 0.0), integrator="rk45", gravity=[0, 0, 0], sensitivities=("x0", "kd"))
    truth = dynamics.simulate(model, q0, v0, 1.0, rtol=1e-12, atol=1e-14, error_estimate="none",
                              **kw).sensitivities[-1]
    for rtol in (1e-6, 1e-8):
        tr = dynamics.simulate(model, q0, v0, 1.0, rtol=rtol, atol=rtol * 1e-2, **kw)
        est = tr.report["sensitivities"]["error_estimate"]
        err = np.abs(tr.sensitivities[-1] - truth).max()
        assert err / 10 <= est <= 10 * err, (rtol, est, err)


def test_spherical_on_planar_under_pd_against_finite_differences():
    model = dynamics.load_urdf(SPHERICAL_ON_PLANAR)
    assert (model.nq, model.nv) == (8, 6)
    q0 = dynamics.integrate(model, model.neutral(), np.array([0.1, -0.2, 0.5, 0.6, -0.4, 0.3]))
    v0 = np.array([0.2, 0.1, -0.5, 1.0, 0.5, -2.0])
    target = model.neutral()

    def pd(name, i, s):
        kp = np.array([5.0, 5.0, 2.0, 1.0, 1.0, 1.0])
        if name == "kp":
            kp[i] += s
        return PD(target, kp, 0.2)
    tr = dynamics.simulate(model, q0, v0, 1.0, torque=pd(None, 0, 0.0), integrator="rk45", rtol=1e-10,
                           atol=1e-12, sensitivities=("x0", "kp"), error_estimate="none", sample_dt=0.1)
    cols = list(range(12)) + [("kp", 2), ("kp", 4)]
    ref, F = tangent_fd(model, q0, v0, 1.0, cols, 1e-5, pd, sample_dt=0.1)
    S = tr.sensitivities[:, :, list(range(12)) + [12 + 2, 12 + 4]]
    assert np.abs(F).max() > 1.0
    assert np.abs(S - F).max() <= 1e-8 * np.abs(F).max(), np.abs(S - F).max()


def test_refusals(body):
    model, q0, v0, pd = body
    with pytest.raises(InputError, match="'q_target' is for models of 1-dof joints"):
        dynamics.simulate(model, q0, v0, 0.1, torque=pd(None, 0, 0.0), sensitivities=("q_target",))
    with pytest.raises(InputError, match="integrator='euler'"):
        dynamics.simulate(model, q0, v0, 0.1, integrator="euler", dt=1e-3, sensitivities=True)


BALL_R = 0.1
BALL = f'<robot name="ball"><link name="ball">{inertial(1.0, 0.004, 0.004, 0.004)}</link></robot>'
CONTACT_TIGHT = dict(TIGHT, rtol=1e-11, atol=1e-13)


def no_torque(q0):
    def pd(name, i, s):  # no stiffness, a faint damping (kd, the parameter)
        kd = np.full(6, 1e-3)
        if name == "kd":
            kd[i] += s
        return PD(q0, 0.0, kd)
    return pd


@pytest.fixture(scope="module")
def ball():
    model = dynamics.load_urdf(BALL, floating_base=True)
    contact = dynamics.Contact(geometries=[dynamics.Sphere("ball", BALL_R)], friction=0.5)
    q0 = np.array([0.0, 0.0, BALL_R + 0.02, 0.0, 0.0, 0.0, 1.0])
    v0 = np.array([0.5, 0.2, -1.0, 3.0, -2.0, 1.0])  # falling, sliding and spinning: friction acts at impact
    return model, contact, q0, v0, no_torque(q0)


def sens_run(model, q0, v0, duration, pd, contact, rtol, **kw):
    return dynamics.simulate(model, q0, v0, duration, torque=pd(None, 0, 0.0), contact=contact, integrator="rk45",
                             rtol=rtol, atol=rtol * 1e-2, sensitivities=("x0", "kd"), **kw)


def test_ball_through_an_impact_against_finite_differences(ball):
    """S after the touch-down (t = 0.0196 s) and through the contact phase: no jump, the differences agree."""
    model, contact, q0, v0, pd = ball
    tr = sens_run(model, q0, v0, 0.06, pd, contact, 1e-10, error_estimate="none", sample_dt=0.01)
    c = tr.report["contact"]
    assert c["max_penetration"] > 1e-4 and c["time_in_contact"] > 0.01
    x0 = [2, 3, 6, 8, 10]  # q0 z and rotation x, v0 x and z, spin about y (differences of 26 runs are slow)
    cols = x0 + [("kd", 0)]
    ref, F = tangent_fd(model, q0, v0, 0.06, cols, 1e-4, pd, CONTACT_TIGHT, contact=contact, sample_dt=0.01)
    S = tr.sensitivities[:, :, x0 + [12]]
    rel = np.abs(S - F).max(axis=(1, 2)) / np.abs(F).max()
    assert np.abs(F[-1]).max() > 1.0
    assert rel[:2].max() <= 1e-9, rel  # in flight
    # after the impact (sample 2, 0.4 ms after the touch-down, is left out): measured 8.6e-6, the same with
    # differences of step 1e-6 and 1e-4 (a systematic error of S through the contact phase, not of the differences)
    assert rel[3:].max() <= 3e-5, rel


def test_ball_error_bound_holds(ball):
    model, contact, q0, v0, pd = ball
    truth = sens_run(model, q0, v0, 0.06, pd, contact, 1e-11, error_estimate="none").sensitivities[-1]
    for rtol in (1e-6, 1e-8):
        tr = sens_run(model, q0, v0, 0.06, pd, contact, rtol)
        est = tr.report["sensitivities"]["error_estimate"]
        err = np.abs(tr.sensitivities[-1] - truth).max()
        assert err / 10 <= est <= 10 * err, (rtol, est, err)
