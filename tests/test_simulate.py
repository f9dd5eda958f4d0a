"""dynamics.simulate against independent references: closed-form equations of motion integrated by scipy at
rtol 1e-12, Pinocchio + scipy, closed-form rigid-body motion, and energy identities."""

import json
import os

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import dynamics
from dynamics.configuration import integrate
from dynamics.simulation import simulate, state_error
from dynamics.torques import PD, ComputedTorque, Table
from robots import chain_urdf


ROBOTS = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "robots")
Q0_2R = np.array([np.pi / 2, np.pi / 4])


@pytest.fixture(scope="module")
def arm2():
    return dynamics.load_urdf(os.path.join(ROBOTS, "planar_2r.urdf"))


# -- the 2R arm's closed form (Spong et al.; numbers from robots/planar_2r.urdf), no Pinocchio ---------------
M1 = M2 = 12.456
L1, LC1, LC2, I1, I2, G = 1.0, 0.773, 0.583, 1.042, 1.042, 9.81


def arm2_accel(q, v, tau):
    c2, s2 = np.cos(q[1]), np.sin(q[1])
    M = np.array([[M1 * LC1 ** 2 + M2 * (L1 ** 2 + LC2 ** 2 + 2 * L1 * LC2 * c2) + I1 + I2,
                   M2 * (LC2 ** 2 + L1 * LC2 * c2) + I2],
                  [M2 * (LC2 ** 2 + L1 * LC2 * c2) + I2, M2 * LC2 ** 2 + I2]])
    h = -M2 * L1 * LC2 * s2
    Cv = np.array([h * (2 * v[0] * v[1] + v[1] ** 2), -h * v[0] ** 2])
    g = np.array([(M1 * LC1 + M2 * L1) * G * np.cos(q[0]) + M2 * LC2 * G * np.cos(q[0] + q[1]),
                  M2 * LC2 * G * np.cos(q[0] + q[1])])
    return np.linalg.solve(M, tau - Cv - g)


def arm2_reference(T, q0=Q0_2R, v0=(0.0, 0.0), tau=lambda t, q, v: np.zeros(2)):
    sol = solve_ivp(lambda t, y: np.r_[y[2:], arm2_accel(y[:2], y[2:], tau(t, y[:2], y[2:]))], (0, T),
                    np.r_[q0, v0], method="DOP853", rtol=1e-12, atol=1e-12)
    return sol.y[:2, -1], sol.y[2:, -1]


def true_error(model, tr, qref, vref):
    return max(state_error(model, tr.q[-1], tr.v[-1], qref, vref))


# -- accuracy and honest error estimates -------------------------------------------------------------------
@pytest.mark.parametrize("integrator, kw", [
    ("rk45", dict(rtol=1e-5, atol=1e-7)), ("rk45", dict(rtol=1e-9, atol=1e-11)),
    ("radau", dict(rtol=1e-6, atol=1e-8)), ("auto", dict(rtol=1e-7, atol=1e-9)),
    ("dop853", dict(rtol=1e-6, atol=1e-8)), ("dop853", dict(rtol=1e-10, atol=1e-12)),
    ("rk4", dict(dt=2e-3)), ("euler", dict(dt=1e-4)),
])
def test_2r_error_estimate_is_honest(arm2, integrator, kw):
    T = 2.0
    qref, vref = arm2_reference(T)
    tr = simulate(arm2, Q0_2R, [0, 0], T, integrator=integrator, **kw)
    err, est = true_error(arm2, tr, qref, vref), tr.report["error_estimate"]
    assert tr.report["status"] == "ok"
    assert err <= 10 * est, (err, est)
    assert est <= 10 * err + 1e-12, (err, est)  # and not uselessly pessimistic
    json.dumps(tr.report)


def test_2r_released_conserves_energy_to_the_tolerance(arm2):
    """The lecture example: released from (90 deg, 45 deg), no torque, 10 s."""
    for rtol, bound in ((1e-6, 1e-4), (1e-10, 1e-8)):
        tr = simulate(arm2, Q0_2R, [0, 0], 10.0, rtol=rtol, atol=rtol * 1e-2, sample_dt=0.5)
        assert tr.report["energy_drift"] < bound
        # the same identity from the public energy functions, independently of the report
        E = [dynamics.kinetic_energy(arm2, q, v) + dynamics.potential_energy(arm2, q) for q, v in zip(tr.q, tr.v)]
        scale = max(np.max([dynamics.kinetic_energy(arm2, q, v) for q, v in zip(tr.q, tr.v)]), 1.0)
        assert abs(E[-1] - E[0]) / scale < bound
        assert tr.t[-1] == 10.0 and len(tr.t) == 21


def test_3r_constant_torque_matches_pinocchio_scipy():
    pin = pytest.importorskip("pinocchio")
    path = os.path.join(ROBOTS, "planar_3r.urdf")
    model = dynamics.load_urdf(path)
    pm = pin.buildModelFromUrdf(path)
    pd = pm.createData()
    q0, v0, tau = np.array([0.3, -0.5, 0.8]), np.array([0.1, 0.0, -0.2]), np.ones(3)
    T = 3.0
    ref = solve_ivp(lambda t, y: np.r_[y[3:], pin.aba(pm, pd, y[:3], y[3:], tau)], (0, T), np.r_[q0, v0],
                    method="DOP853", rtol=1e-12, atol=1e-12).y[:, -1]
    for integrator in ("rk45", "dop853", "radau"):
        tr = simulate(model, q0, v0, T, torque=tau, integrator=integrator, rtol=1e-10, atol=1e-12)
        assert np.abs(np.r_[tr.q[-1], tr.v[-1]] - ref).max() < 1e-7
        assert np.allclose(tr.tau, 1.0)
        # work of the constant torque = tau . (q(T) - q(0)), exactly
        assert tr.report["work_torque"] == pytest.approx(tau @ (tr.q[-1] - q0), rel=1e-8)


def _circle_reference(T=10.0, a=1.0, b=0.6, r=0.3, dt=1e-3):
    """Joint trajectory of the 2R tip on x = a + r cos(phi), y = b + r sin(phi), phi = 2 pi t / T
    (analytic inverse kinematics, elbow down, and its first two derivatives)."""
    t = np.arange(0.0, T + dt / 2, dt)
    w = 2 * np.pi / T
    x, y = a + r * np.cos(w * t), b + r * np.sin(w * t)
    xd, yd = -r * w * np.sin(w * t), r * w * np.cos(w * t)
    xdd, ydd = -r * w * w * np.cos(w * t), -r * w * w * np.sin(w * t)
    c2 = (x * x + y * y - 2.0) / 2.0
    q2 = np.arccos(c2)
    q1 = np.arctan2(y, x) - np.arctan2(np.sin(q2), 1 + np.cos(q2))
    q = np.stack([q1, q2], 1)
    v, acc = np.zeros_like(q), np.zeros_like(q)
    for k in range(len(t)):
        s1, s12, c1, c12 = np.sin(q1[k]), np.sin(q1[k] + q2[k]), np.cos(q1[k]), np.cos(q1[k] + q2[k])
        Jm = np.array([[-s1 - s12, -s12], [c1 + c12, c12]])
        v[k] = np.linalg.solve(Jm, [xd[k], yd[k]])
        u1, u12 = v[k, 0], v[k, 0] + v[k, 1]
        Jdv = np.array([-c1 * u1 * u1 - c12 * u12 * u12, -s1 * u1 * u1 - s12 * u12 * u12])
        acc[k] = np.linalg.solve(Jm, np.array([xdd[k], ydd[k]]) - Jdv)
    return t, q, v, acc


def test_2r_computed_torque_tracks_a_circle(arm2):
    t, q, v, a = _circle_reference()
    ct = ComputedTorque(t, q, v, a, kp=100.0, kd=20.0)
    tr = simulate(arm2, q[0], v[0], 10.0, torque=ct, rtol=1e-10, atol=1e-12, sample_dt=0.01)
    k = np.round(tr.t / 1e-3).astype(int)  # samples fall on reference knots
    assert np.abs(tr.q - q[k]).max() < 1e-6
    # the torques are the inverse dynamics along the path
    tau_id = dynamics.inverse_dynamics(arm2, q[k], v[k], a[k])
    assert np.abs(tr.tau - tau_id).max() < 1e-6 * np.abs(tau_id).max()
    # the tip really is on the circle
    tip = np.stack([np.cos(tr.q[:, 0]) + np.cos(tr.q.sum(1)), np.sin(tr.q[:, 0]) + np.sin(tr.q.sum(1))], 1)
    assert np.abs(np.hypot(tip[:, 0] - 1.0, tip[:, 1] - 0.6) - 0.3).max() < 1e-5


# -- torque sources: compiled kinds against the same law as a Python callable --------------------------------
def test_torque_sources_match_python_callables(arm2):
    T, kw = 1.0, dict(rtol=1e-9, atol=1e-11, sample_dt=0.1)
    tt = np.linspace(0, T, 6)
    tab = np.stack([np.sin(3 * tt), np.cos(2 * tt)], 1) * 20
    qt = np.array([0.5, -0.3])
    cases = [
        (Table(tt, tab), lambda t, q, v: np.array([np.interp(t, tt, tab[:, 0]), np.interp(t, tt, tab[:, 1])])),
        (Table(tt, tab, hold="zoh"), lambda t, q, v: tab[min(np.searchsorted(tt, t, "right") - 1, 5)]),
        (PD(qt, kp=[200, 100], kd=[20, 10]), lambda t, q, v: np.array([200, 100]) * (qt - q) - [20, 10] * v),
        ([3.0, -2.0], lambda t, q, v: np.array([3.0, -2.0])),
    ]
    for compiled, fn in cases:
        a = simulate(arm2, Q0_2R, [0, 0], T, torque=compiled, **kw)
        b = simulate(arm2, Q0_2R, [0, 0], T, torque=fn, **kw)
        assert np.abs(a.q - b.q).max() < 1e-9 and np.abs(a.tau - b.tau).max() < 1e-8
        assert a.report["energy_drift"] < 1e-6  # the work of the torques balances the energy


def test_callable_gets_checked(arm2):
    with pytest.raises(dynamics.InputError, match="torque"):
        simulate(arm2, Q0_2R, [0, 0], 0.1, torque=lambda t, q, v: np.zeros(3))


# -- floating base: closed-form free fall of a spinning body ----------------------------------------------------
BOX = """<robot name="box"><link name="box"><inertial><origin xyz="0 0 0"/><mass value="2"/>
<inertia ixx="0.1" ixy="0" ixz="0" iyy="0.2" iyz="0" izz="0.3"/></inertial></link></robot>"""


def test_free_flyer_spinning_free_fall():
    model = dynamics.load_urdf(BOX, floating_base=True)
    w = 3.0  # about the principal z axis: uniform rotation
    q0 = np.array([0.1, 0.2, 1.0, 0, 0, 0, 1.0])
    v0 = np.array([0, 0, 0, 0, 0, w])
    T = 2.0
    tr = simulate(model, q0, v0, T, rtol=1e-11, atol=1e-12, sample_dt=0.25)
    for t, q in zip(tr.t, tr.q):
        assert np.linalg.norm(q[3:]) == pytest.approx(1.0, abs=1e-14)
        expect = np.r_[0.1, 0.2, 1.0 - 0.5 * 9.81 * t * t, 0, 0, np.sin(w * t / 2), np.cos(w * t / 2)]
        d = state_error(model, q, np.zeros(6), expect, np.zeros(6))[0]
        assert d < 1e-8
    # and a tumbling body keeps its angular momentum and energy (no gravity)
    v1 = np.array([0.3, -0.2, 0.1, 1.0, 2.0, 0.5])
    tr = simulate(model, q0, v1, T, gravity=[0, 0, 0], rtol=1e-10, atol=1e-12)
    assert tr.report["energy_drift"] < 1e-8


def test_integrate_matches_pinocchio_on_a_free_flyer():
    pin = pytest.importorskip("pinocchio")
    model = dynamics.load_urdf(BOX, floating_base=True)
    pm = pin.buildModelFromUrdf(_write(BOX), pin.JointModelFreeFlyer())
    rng = np.random.default_rng(3)
    for _ in range(5):
        q = pin.randomConfiguration(pm, -np.ones(7), np.ones(7))
        v = rng.normal(size=6) * 3
        ours, theirs = integrate(model, q, v, 0.7), pin.integrate(pm, q, 0.7 * v)
        sign = np.sign(ours[6] * theirs[6])  # q and -q are the same rotation
        assert np.abs(ours[:3] - theirs[:3]).max() < 1e-13 and np.abs(ours[3:] - sign * theirs[3:]).max() < 1e-13
        assert np.linalg.norm(ours[3:]) == pytest.approx(1.0, abs=1e-15)


def _write(text, _cache={}):
    import tempfile
    if text not in _cache:
        f = tempfile.NamedTemporaryFile("w", suffix=".urdf", delete=False)
        f.write(text)
        f.close()
        _cache[text] = f.name
    return _cache[text]


# -- stiff and extreme cases ----------------------------------------------------------------------------------
def mixed_chain(masses, inertias, damping=0.0, length=0.3):
    """A planar chain (about y) with per-link masses and inertias."""
    parts = ['<robot name="mixed"><link name="base"/>']
    for i, (m, I) in enumerate(zip(masses, inertias)):
        parts.append(f'<link name="l{i}"><inertial><origin xyz="0 0 {-length / 2}"/><mass value="{m}"/>'
                     f'<inertia ixx="{I}" ixy="0" ixz="0" iyy="{I}" iyz="0" izz="{I}"/></inertial></link>')
        parts.append(f'<joint name="j{i}" type="continuous"><parent link="{"base" if i == 0 else f"l{i - 1}"}"/>'
                     f'<child link="l{i}"/><origin xyz="0 0 {0 if i == 0 else -length}"/><axis xyz="0 1 0"/>'
                     f'<dynamics damping="{damping}"/></joint>')
    return "".join(parts) + "</robot>"


@pytest.mark.parametrize("damping", [1e3, 1e5])
def test_heavily_damped_chain(damping):
    model = dynamics.load_urdf(chain_urdf(6, damping=damping))
    q0 = np.linspace(0.2, 1.2, 6)
    v0 = np.ones(6)
    tr = simulate(model, q0, v0, 0.5, integrator="auto", rtol=1e-6, atol=1e-8)
    r = tr.report
    assert r["status"] == "ok" and r["switches"] and r["switches"][0]["to"] == "radau"
    assert r["steps"] < 5000 and np.all(np.isfinite(tr.q))
    ref = simulate(model, q0, v0, 0.5, integrator="radau", rtol=1e-11, atol=1e-13, error_estimate="none")
    err = true_error(model, tr, ref.q[-1], ref.v[-1])
    assert err < 1e-4 and err <= 10 * r["error_estimate"]
    assert r["energy_drift"] < 1e-4 and r["work_passive"] < 0  # dissipated by the dampers
    # an explicit method past its stability limit is detected before and during the run
    bad = simulate(model, q0, v0, 0.5, integrator="rk4", dt=1e-3)
    assert bad.report["status"].startswith("unstable")
    assert any("stability limit" in w for w in bad.report["warnings"])
    assert np.all(np.isfinite(bad.q)) and bad.t[-1] < 0.5


def test_joint_limit_springs_hit_at_speed(arm2):
    tr = simulate(arm2, [0.0, 2.9], [0.0, 8.0], 1.0, limits="spring", limit_stiffness=1e5, limit_damping=1e3,
                  rtol=1e-7, atol=1e-9)
    assert tr.report["status"] == "ok"
    assert tr.q[:, 1].max() < np.pi + 0.1  # bounced off the upper limit (pi)
    ref = simulate(arm2, [0.0, 2.9], [0.0, 8.0], 1.0, limits="spring", limit_stiffness=1e5, limit_damping=1e3,
                   integrator="radau", rtol=1e-11, atol=1e-13, error_estimate="none")
    err = true_error(arm2, tr, ref.q[-1], ref.v[-1])
    assert err < 1e-3 and err <= 10 * tr.report["error_estimate"]
    assert tr.report["energy_drift"] < 1e-4


@pytest.mark.parametrize("masses, inertias, v0", [
    ([100, 100, 100, 1e-6], [1, 1, 1, 1e-9], 1.0),  # a micro-gram tip on heavy links
    ([1, 1, 1], [1e-9, 1e-9, 1e-9], 1.0),  # point masses
    ([1, 1, 1], [1e-3, 1e-3, 1e-3], 100.0),  # 100 rad/s
])
def test_extreme_parameters(masses, inertias, v0):
    model = dynamics.load_urdf(mixed_chain(masses, inertias))
    n = len(masses)
    q0 = np.r_[0.5, np.full(n - 1, 1e-3)]  # links nearly aligned (near singular for the tip)
    T = 0.2
    tr = simulate(model, q0, np.full(n, v0), T, rtol=1e-7, atol=1e-9)
    assert tr.report["status"] == "ok" and np.all(np.isfinite(tr.v))
    ref = simulate(model, q0, np.full(n, v0), T, rtol=1e-12, atol=1e-13, error_estimate="none")
    err = true_error(model, tr, ref.q[-1], ref.v[-1])
    assert err <= 10 * tr.report["error_estimate"] and err < 1e-4 * max(1.0, v0)


def test_long_chain_runs():
    model = dynamics.load_urdf(chain_urdf(200))
    tr = simulate(model, np.full(200, 0.01), np.zeros(200), 0.005, integrator="rk4", dt=1e-3,
                  error_estimate="none")
    assert tr.report["status"] == "ok" and tr.report["rhs_evals"] == 4 * 5 + 1


def test_conservative_chain_energy_over_10s():
    model = dynamics.load_urdf(chain_urdf(5))
    tr = simulate(model, np.linspace(0.5, 1.5, 5), np.zeros(5), 10.0, integrator="rk45", rtol=1e-12, atol=1e-14,
                  error_estimate="none", sample_dt=1.0)
    assert tr.report["energy_drift"] < 1e-8


# -- inputs -----------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("kwargs, match", [
    (dict(q0=[0.0]), r"q0: expected shape \(2,\)"),
    (dict(v0=[0.0, np.nan]), "v0: contains non-finite"),
    (dict(duration=-1.0), "duration"),
    (dict(rtol=-1e-6), "rtol"),
    (dict(atol=-1.0), "atol"),
    (dict(integrator="rk4"), "dt: required"),
    (dict(integrator="leapfrog"), "integrator"),
    (dict(sample_dt=0.0), "sample_dt"),
    (dict(gravity=[0, 0]), "gravity"),
    (dict(torque=[1.0, 2.0, 3.0]), "torque"),
    (dict(limits="hard"), "limits"),
    (dict(max_steps=10), "max_steps"),
    (dict(integrator="euler", dt=1e-7), "max_steps"),
])
def test_bad_input(arm2, kwargs, match):
    args = dict(q0=Q0_2R, v0=[0.0, 0.0], duration=1.0)
    args.update(kwargs)
    with pytest.raises(dynamics.InputError, match=match):
        simulate(arm2, args.pop("q0"), args.pop("v0"), args.pop("duration"), **args)


def test_report_fields(arm2):
    tr = simulate(arm2, Q0_2R, [0, 0], 0.3, sample_dt=0.1)
    r = json.loads(json.dumps(tr.report))
    for key in ("integrator", "switches", "steps", "rejected_steps", "rhs_evals", "wall_time_s", "error_estimate",
                "energy_drift", "warnings", "status"):
        assert key in r
    assert tr.q.shape == (4, 2) and tr.v.shape == (4, 2) and tr.tau.shape == (4, 2)
    assert np.allclose(tr.t, [0, 0.1, 0.2, 0.3])
