"""A ball dropped on the ground (issue 19, section 5): its restitution against the closed form of the contact law,
its bounce heights against a 1-D integration of the same law, its energy never rising, the report's error
estimate against the true error through the impacts, and the fixed-step warning.

The closed form: a sphere hitting a plane at speed v0 with no gravity obeys m x'' = -k x (1 + d x') (x the
penetration, x' > 0 inwards).  Dividing by x' and integrating over the impact (x from 0 back to 0, so the spring
term integrates to zero):  int_{v0}^{-v1} u / (1 + d u) du = 0, i.e.

    d (v0 + v1) = ln((1 + d v0) / (1 - d v1)),        e = v1 / v0 ~ 1 - (2/3) d v0 for small d v0,

exact for this law at any stiffness (the clamp (.)_+ never acts: the speed stays below 1/d on the way out).
"""

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

import dynamics

M, R, K, D = 1.0, 0.1, 1e7, 0.2
BALL = f"""<robot name="ball"><link name="ball"><inertial><mass value="{M}"/>
<inertia ixx="{0.4 * M * R * R}" iyy="{0.4 * M * R * R}" izz="{0.4 * M * R * R}" ixy="0" ixz="0" iyz="0"/>
</inertial></link></robot>"""
G = 9.81


@pytest.fixture(scope="module")
def ball():
    model = dynamics.load_urdf(BALL, floating_base=True)
    contact = dynamics.Contact(geometries=[dynamics.Sphere("ball", R)],
                               friction=dynamics.Material(stiffness=2 * K, dissipation=D),  # 2K: the ground's too
                               outputs=("contacts",))
    return model, contact


def exit_speed(v0, d=D):
    """v1 of the closed form (module docstring)."""
    return brentq(lambda v1: d * (v0 + v1) - math.log((1 + d * v0) / (1 - d * v1)), 1e-12, min(v0, 1 / d) * (1 - 1e-15))


def state(z, vz):
    return np.array([0.0, 0.0, z, 0.0, 0.0, 0.0, 1.0]), np.array([0.0, 0.0, vz, 0.0, 0.0, 0.0])


@pytest.mark.parametrize("v0", [0.5, 2.0])
def test_restitution_is_the_closed_form(ball, v0):
    model, contact = ball
    q0, v0_ = state(R + 1e-3, -v0)
    traj = dynamics.simulate(model, q0, v0_, 0.01, contact=contact, gravity=[0, 0, 0], rtol=1e-12, atol=1e-14,
                             error_estimate="none")
    v1 = exit_speed(v0)
    assert traj.q[-1, 2] > R  # it left the ground
    assert traj.v[-1, 2] == pytest.approx(v1, rel=1e-7)
    assert v1 / v0 == pytest.approx(1 - 2 / 3 * D * v0, abs=(D * v0) ** 2)  # the small-velocity regime
    c = traj.report["contact"]
    assert c["energy_dissipated"] == pytest.approx(0.5 * M * (v0**2 - v1**2), rel=1e-7)
    assert c["max_penetration"] > 0.5 * v0 * math.sqrt(M / K)  # ~ v0 sqrt(m/k) less the damping's share


def _reference_apexes(h0, n, d=D, k=K):
    """Apex heights (of the ball's bottom) of the same law in 1-D with gravity, at rtol 1e-12."""
    def f(t, y):
        x = R - y[0]
        fn = k * x * max(0.0, 1 - d * y[1]) if x > 0 else 0.0
        return [y[1], -G + fn / M]
    apex = lambda t, y: y[1]
    apex.direction = -1
    sol = solve_ivp(f, (0, 10), [R + h0, 0.0], method="DOP853", rtol=1e-12, atol=1e-14, events=apex,
                    max_step=2e-4)
    return sol.y_events[0][1:n + 1, 0] - R


def _flight_apexes(traj):
    """Apex heights from the samples in flight: E / (m g) of each flight between two contacts."""
    z, vz = traj.q[:, 2], traj.v[:, 2]
    flying = traj.contacts.count == 0
    out, seg = [], []
    for k in range(1, len(z)):
        if flying[k] and z[k] > R:
            seg.append(z[k] - R + vz[k] ** 2 / (2 * G))
        elif seg:
            out.append(np.median(seg))
            seg = []
    return np.array(out[1:])  # the first flight is the drop


def test_bounce_heights_and_energy(ball):
    model, contact = ball
    h0 = 0.1
    q0, v0 = state(R + h0, 0.0)
    traj = dynamics.simulate(model, q0, v0, 0.9, contact=contact, rtol=1e-12, atol=1e-14, sample_dt=5e-4,
                             error_estimate="none")
    got = _flight_apexes(traj)
    assert len(got) >= 3
    want = _reference_apexes(h0, len(got))
    assert np.allclose(got, want, rtol=1e-6)
    # the closed form, bounce by bounce (gravity during the ~1 ms impact changes it by ~m g / (k x_max) ~ 1e-3)
    for before, after in zip([h0, *got[:-1]], got):
        assert after == pytest.approx(exit_speed(math.sqrt(2 * G * before)) ** 2 / (2 * G), rel=3e-3)
    # the energy (kinetic + potential + elastic 1/2 k x^2) never rises
    E = 0.5 * M * np.sum(traj.v[:, :3] ** 2, axis=1) + M * G * traj.q[:, 2] + 0.5 * K * traj.contacts.depth[:, 0] ** 2
    assert np.all(np.diff(E) <= 1e-9 * E[0])
    assert E[0] - E[-1] > 0.5 * M * G * h0  # more than half the drop height lost in three bounces
    rep = traj.report
    assert rep["energy_drift"] < 1e-8
    assert rep["contact"]["energy_dissipated"] == pytest.approx(E[0] - E[-1], rel=1e-7)


def test_error_estimate_is_honest_through_impacts(ball):
    """The report's estimate at the default tolerance against the error measured on a run at rtol 1e-12."""
    model, contact = ball
    q0, v0 = state(R + 0.2, 0.0)
    ref = dynamics.simulate(model, q0, v0, 0.8, contact=contact, rtol=1e-12, atol=1e-14, error_estimate="none")
    ratios = []
    for rtol in (1e-5, 1e-7):
        traj = dynamics.simulate(model, q0, v0, 0.8, contact=contact, rtol=rtol, atol=rtol * 1e-2)
        eq, ev = dynamics.simulation.state_error(model, traj.q[-1], traj.v[-1], ref.q[-1], ref.v[-1])
        ratios.append(traj.report["error_estimate"] / max(eq, ev))
    assert all(0.1 <= r <= 10 for r in ratios), ratios


def test_fixed_step_warns_when_dt_is_too_large(ball):
    model, contact = ball
    q0, v0 = state(R + 0.01, 0.0)
    with pytest.warns(dynamics.SimulationWarning, match="too large for the contact"):
        traj = dynamics.simulate(model, q0, v0, 0.02, contact=contact, integrator="rk4", dt=1e-3,
                                 error_estimate="none")
    st = traj.report["stability"]
    assert st["dt_times_contact_spectral_radius"] > st["limit"]
    # the estimate: omega = sqrt(k / m) for this undamped-at-rest contact, and the friction slope 2 mu g / v_s
    assert st["contact_spectral_radius"] >= math.sqrt(K / M)
    ok = dynamics.simulate(model, q0, v0, 0.02, contact=contact, integrator="rk4", dt=0.5 * st["limit"]
                           / st["contact_spectral_radius"], error_estimate="none")
    assert ok.report["status"] == "ok" and "stability" in ok.report


def test_simulate_many_stacks_the_contacts(ball):
    """Two drops (1 m and 0.5 m) through simulate_many: each run's stacked contacts are simulate's, bit for bit;
    the pair names are shared; the lower drop touches down first."""
    model, contact = ball
    q0 = np.array([[0.0, 0.0, h, 0.0, 0.0, 0.0, 1.0] for h in (1.0, 0.5)])
    runs = dynamics.simulate_many(model, q0, np.zeros(6), 0.6, contact=contact, rtol=1e-8, atol=1e-10,
                                  error_estimate="none", progress=False)
    c = runs.contacts
    T = runs.t.shape[0]
    assert c.count.shape == (2, T) and c.point.shape[:2] == (2, T) and c.pairs == [("ball/sphere0", "ground")]
    for k in range(2):
        one = dynamics.simulate(model, q0[k], np.zeros(6), 0.6, contact=contact, rtol=1e-8, atol=1e-10,
                                error_estimate="none").contacts
        for stacked, alone in zip(c[:8], one[:8]):
            np.testing.assert_array_equal(stacked[k], alone)
    touch = [runs.t[np.argmax(c.count[k] > 0)] for k in range(2)]
    assert touch[1] < touch[0]
    np.testing.assert_allclose(touch, [math.sqrt(2 * (h - R) / G) for h in (1.0, 0.5)], atol=2e-3)
