"""A quadruped standing (issue 19, section 5): Go1 from example-robot-data with a sphere declared on each foot,
under PD and gravity compensation on the default material: at rest the normal forces carry its weight (sum f_n
= m g to 1e-6), the feet do not creep, ``auto`` switched to radau for the contact's stiffness and says so; and
simulate_many runs contact too."""

import numpy as np
import pytest

import dynamics
from robots import erd

FEET = ["FR_foot", "FL_foot", "RR_foot", "RL_foot"]
R_FOOT = 0.02
G = 9.81


@pytest.fixture(scope="module")
def go1():
    model = dynamics.load_urdf(erd("go1_description/urdf/go1.urdf"), floating_base=True, strict_inertia=False)
    q = model.neutral().copy()
    for leg in ("FR", "FL", "RR", "RL"):
        for joint, angle in (("hip", 0.0), ("thigh", 0.9), ("calf", -1.8)):
            q[model.q_index[model.joint_names.index(f"{leg}_{joint}_joint")]] = angle
    q[:3] = 0.0
    mass = float(np.sum(model.tree.mass))
    contact = dynamics.Contact(geometries=[dynamics.Sphere(f, R_FOOT) for f in FEET])
    k = mass * G / contact.friction.penetration_allowance  # the default stiffness of a foot on the ground
    q[2] = -dynamics.frame_placement(model, q, FEET[0])[2, 3] + R_FOOT - mass * G / (4 * k)
    # gravity compensation: the joint torques holding the pose with a quarter of the weight on each foot
    tau_ff = dynamics.gravity_torques(model, q)
    for f in FEET:
        tau_ff -= dynamics.frame_jacobian(model, q, f)[:3].T @ np.array([0.0, 0.0, mass * G / 4])
    tau_ff[:6] = 0.0  # the free joint is not actuated
    kp = np.r_[np.zeros(6), np.full(12, 50.0)]
    kd = np.r_[np.zeros(6), np.full(12, 1.0)]
    pd = dynamics.torques.PD(q.copy(), kp, kd, tau_ff=tau_ff)
    return model, q, mass, contact, pd


@pytest.fixture(scope="module")
def standing(go1):
    model, q0, mass, contact, pd = go1
    return dynamics.simulate(model, q0, np.zeros(model.nv), 1.0, torque=pd, contact=contact, rtol=1e-8, atol=1e-10,
                             error_estimate="none")


def test_normal_forces_carry_the_weight_at_rest(go1, standing):
    model, q0, mass, contact, pd = go1
    traj = standing
    assert traj.report["status"] == "ok"
    f_ext, det = dynamics.contact_forces(model, contact, traj.q[-1], traj.v[-1], details=True)
    assert len(det.normal_force) == 4 and sorted(p[0] for p in det.pairs) == sorted(FEET[i] + "/sphere" + str(i)
                                                                                  for i in range(4))
    assert det.normal_force.sum() == pytest.approx(mass * G, rel=1e-6)
    assert np.abs(traj.v[-1]).max() < 1e-3
    # no creep: each foot moves less than 10 um along the ground over the last half second
    i = np.searchsorted(traj.t, 0.5)
    for f in FEET:
        slide = dynamics.frame_placement(model, traj.q[-1], f)[:2, 3] - dynamics.frame_placement(model, traj.q[i], f)[:2, 3]
        assert np.linalg.norm(slide) < 1e-5
    c = traj.report["contact"]
    assert c["time_in_contact"] == pytest.approx(1.0)
    assert 0 < c["max_penetration"] < contact.friction.penetration_allowance
    assert any(s["to"] == "radau" for s in traj.report["switches"]) and "stiff" in c


def test_simulate_many_with_contact(go1, standing):
    """The same run through simulate_many (bit for bit, as simulate_many promises), and a second, dropped from
    5 mm higher, which settles to the same weight."""
    model, q0, mass, contact, pd = go1
    q1 = q0.copy()
    q1[2] += 0.005
    runs = dynamics.simulate_many(model, np.array([q0, q1]), np.zeros(model.nv), 1.0, torque=pd, contact=contact,
                                  rtol=1e-8, atol=1e-10, error_estimate="none", progress=False)
    assert np.array_equal(runs.q[0], standing.q) and runs.ok.all()
    det = dynamics.contact_forces(model, contact, runs.q[1, -1], runs.v[1, -1], details=True)[1]
    assert det.normal_force.sum() == pytest.approx(mass * G, rel=1e-3)
    assert runs.reports[1]["contact"]["max_penetration"] > runs.reports[0]["contact"]["max_penetration"]


@pytest.mark.parametrize("rtol", [1e-2, 1e-3])
def test_auto_switches_at_touchdown_at_loose_tolerances(go1, standing, rtol):
    """At loose tolerances DOPRI5's stiffness estimate stays under its threshold on a standing robot (the stiff
    direction, the regularised friction, is a small part of the state's norm), and rk45 used to crawl at its
    stability limit: over 40,000 steps for 0.3 s at rtol 1e-3, and no switch at all at 1e-2.  ``auto`` now
    switches to radau at the first accepted state that touches, says why, and stands like the tight run."""
    model, q0, mass, contact, pd = go1
    traj = dynamics.simulate(model, q0, np.zeros(model.nv), 1.0, torque=pd, contact=contact, rtol=rtol,
                             error_estimate="none")
    r = traj.report
    assert r["status"] == "ok"
    assert r["switches"][0]["to"] == "radau" and "contact" in r["switches"][0]["reason"]
    assert r["switches"][0]["t"] == 0.0  # it starts standing
    assert r["steps"] < 500
    assert np.abs(traj.q[-1] - standing.q[-1]).max() < 1e-3
